"""Run the firmware on a simulated handheld: in-process (CPython), in an interpreter on the
simulation HAL, or as a board runs it (its own HAL on stand-ins for the board's C modules).

    from desktop.devicesim.runners import start_device
    from desktop.devicesim.world import make_world
    world = make_world(serial=None, motion="hand", seconds=60, seed=1)
    dev = start_device(world, root, kind="micropython")     # or "cpython"
    dev.run_until(1.0); world.press(0.2); dev.run_until(40.0)
    dev.close()

InProcessDevice and MicroPythonDevice run the same device/ code through
device/sim/hal_sim.py: in this process, or the "sim" runtime's image
(desktop/firmware/image.py) in an interpreter as a child process, its link
(device/sim/sim_link.py) on the child's stdin/stdout, answered by
link_host.HostLink. BoardDevice deploys the "micropython" or "circuitpython"
runtime's files and runs its own HAL (hal_micropython.py, hal_circuitpython.py)
on the stand-ins of stand-ins/ (simboard.py has the wiring); the serial line is
then the child's stdin/stdout, the link two more pipes. The board's flash is
the folder ROOT/flash.
"""

import fcntl
import os
import shutil
import subprocess
import threading

from desktop.devicesim.costs import COSTS_S, costs_us
from desktop.devicesim.link_host import HostLink
from desktop.firmware.files import SIM, import_device, root_files
from desktop.firmware.image import build_image
from desktop.firmware.interpreters import interpreter as interpreter_path

HEAP = "256K"   # an rp2040 gives MicroPython ~200 KB of heap; a little slack for the sim link
# The 64-bit unix builds (micropython, micropython-float32) double every pointer: the same
# firmware takes 119,904 B after boot there against 82,176 B on a 32-bit build (python -m
# desktop.bench.heap), 1.46 times, so the 32-bit board's 256 KB is ~374 KB here. (320 KB, the
# figure of a smaller firmware, ran out in a quick re-calibration on micropython-float32.)
HEAP_64 = "384K"
WORD_64 = ("micropython", "micropython-float32")


def heap_for(interpreter, heap=None):
    """The heap a simulated board gets: as asked, else by the interpreter's word size."""
    return heap or (HEAP_64 if interpreter in WORD_64 else HEAP)
STAND_INS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "stand-ins")


def flash_dir(root):
    fs = os.path.join(root, "flash")
    os.makedirs(fs, exist_ok=True)
    return fs


def write_config(root, **settings):
    """Put a config.json on the simulated flash before boot (what a user does once per board)."""
    import_device("store").save(flash_dir(root), "config", settings)


class DeviceDied(RuntimeError):
    pass


class InProcessDevice:
    """The firmware's modules imported into this CPython process; World is the link.

    The firmware boots and runs its own main loop (App.run) in a thread that
    has the turn only while run_until waits: when it idles with the world's
    time up, the World parks it (World.on_due) and hands the turn back, as the
    pipe runner's host does with the `micropython` process; it boots during the
    first run_until, as that process does. One thread runs at a time, so the
    run is deterministic and sees the same sequence of events as the pipe
    runner's. `app` and `board` exist from the first run_until on;
    on_boot(device) runs in between, before the first conversion is serviced.
    """

    kind = "cpython"

    def __init__(self, world, root, polled=False, costs=COSTS_S, on_boot=None):
        self.world = world
        self._boot = (flash_dir(root), polled, costs_us(costs), on_boot)
        self.board = self.app = None
        self._turn = threading.Condition()
        self._firmware_has_turn = False
        self._thread = None
        self._error = None
        world.on_due = self._park

    def _park(self):
        if threading.current_thread() is not self._thread:
            return   # a test driving the board from its own thread: nothing to hand back
        with self._turn:
            self._firmware_has_turn = False
            self._turn.notify_all()
            self._turn.wait_for(lambda: self._firmware_has_turn)

    def _main(self):
        try:
            fs, polled, costs, on_boot = self._boot
            self.board = import_device("hal_sim").Board(self.world, fs, polled=polled, costs=costs)
            self.app = import_device("app").App(self.board)
            if on_boot is not None:
                on_boot(self)
            self.app.run()
        except BaseException as e:  # noqa: B036 - reported by run_until in the caller's thread
            self._error = e
        finally:
            with self._turn:
                self._firmware_has_turn = False
                self._turn.notify_all()

    def _give_turn(self):
        with self._turn:
            self._firmware_has_turn = True
            if self._thread is None:
                self._thread = threading.Thread(target=self._main, name="firmware", daemon=True)
                self._thread.start()
            else:
                self._turn.notify_all()
            self._turn.wait_for(lambda: not self._firmware_has_turn)
        if self._error is not None:
            raise DeviceDied("the firmware raised %r" % (self._error,)) from self._error

    def run_until(self, t):
        """Let the firmware run until it idles with the world at `t` s (or it stops)."""
        self.world.until = t
        if self._thread is None or self._thread.is_alive():
            self._give_turn()

    def close(self):
        if self._thread is not None and self._thread.is_alive():
            self.world.quit = True
            self._give_turn()
            self._thread.join(timeout=5)
        self.world.close()


class _ChildDevice:
    """What both child-process devices share: the link's messages and its service loop."""

    @property
    def messages(self):
        return self.link.messages

    def run_until(self, t):
        self.link.serve(t)

    def _stop(self):
        """Ask the firmware to quit over the link; False when it is already gone."""
        if self.proc.poll() is not None:
            return False
        try:
            self.link.quit()
        except (BrokenPipeError, OSError):
            pass
        return True


class MicroPythonDevice(_ChildDevice):
    """The firmware's image in a MicroPython (or CircuitPython) executable, its HAL piped to the World.

    interpreter: a name of desktop/firmware/interpreters.py (the pip `micropython`
    by default); the MicroPython builds run the .mpy image, CircuitPython the
    sources (it refuses MicroPython's .mpy).
    """

    kind = "micropython"

    def __init__(self, world, root, interpreter="micropython", heap=None, lock_heap_in_isr=True, polled=False,
                 costs=COSTS_S):
        exe = interpreter_path(interpreter)
        if exe is None:
            raise FileNotFoundError("no %s executable (python -m desktop.firmware.interpreters list)" % interpreter)
        self.interpreter = interpreter
        self.world = world
        self.errfile = open(os.path.join(root, "micropython.stderr"), "w+b")
        lib = build_image(os.path.join(root, "lib"), runtime="sim", compiled=not interpreter.startswith("circuitpython"))
        boot = ("import sys\nsys.path[:0] = [%r]\nimport sim_main\nsim_main.run(%r, %r, %r, %r)\n"
                % (lib, flash_dir(root), bool(lock_heap_in_isr), bool(polled), costs_us(costs)))
        self.proc = subprocess.Popen([exe, "-X", "heapsize=" + heap_for(interpreter, heap), "-c", boot], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.errfile, bufsize=0)
        self._fd = self.proc.stdout.fileno()
        self._ahead = b""       # bytes of the firmware's next messages, read with an earlier one
        self.link = HostLink(world, self._read, self.proc.stdin.write)

    def _read(self, n):
        """Exactly n bytes of the firmware's messages. One read takes whatever the pipe holds
        (the firmware writes messages without a reply back to back), the rest serves the
        next calls: a system call per wait of the firmware, not per message."""
        buf = self._ahead
        while len(buf) < n:
            chunk = os.read(self._fd, 65536)
            if not chunk:
                self._died()
            buf += chunk
        self._ahead = buf[n:]
        return buf[:n]

    def _died(self):
        self.proc.wait(timeout=5)
        self.errfile.seek(0)
        err = self.errfile.read().decode(errors="replace").strip()
        raise DeviceDied("micropython exited (%s): %s" % (self.proc.returncode, err[-2000:]))

    def close(self):
        if self._stop():
            try:
                self.proc.stdin.close()
            except (BrokenPipeError, OSError):
                pass
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.errfile.close()
        self.world.close()


def install_firmware(flash, runtime):
    """The runtime's firmware files in a board's flash folder: lib/ (.mpy for MicroPython,
    sources for CircuitPython, whose interpreter refuses MicroPython's .mpy) and the entry points."""
    build_image(os.path.join(flash, "lib"), runtime=runtime, compiled=runtime == "micropython")
    for src, name in root_files(runtime):
        shutil.copyfile(src, os.path.join(flash, name))


def board_rom(rom, runtime):
    """A simulated board's ROM folder: the stand-ins for the runtime's C modules, the wiring
    (simboard.py) and the simulation link, as frozen modules sit on a board."""
    os.makedirs(rom, exist_ok=True)
    for src in [os.path.join(STAND_INS, "simboard.py")] + [os.path.join(SIM, f) for f in ("sim_link.py", "sim_wire.py")] + \
            [os.path.join(STAND_INS, runtime, f) for f in sorted(os.listdir(os.path.join(STAND_INS, runtime)))
             if f.endswith(".py")]:     # (an installed copy also holds __pycache__/)
        shutil.copyfile(src, os.path.join(rom, os.path.basename(src)))
    return rom


def board_env(rom, flash, fds):
    """The environment of a simulated board's interpreter: ROM, then the flash's lib/, on its
    path; the link's two pipes (to the firmware, from it)."""
    return dict(os.environ, MICROPYPATH=":".join([rom, os.path.join(flash, "lib")]),
                FLUXCAL_SIMBOARD_FDS="%d,%d" % fds)


class BoardDevice(_ChildDevice):
    """The firmware as a board runs it, on stand-ins for the board's C modules.

    The runtime's files (device/manifest.py: "micropython" with hal_micropython.py,
    main.py; "circuitpython" with hal_circuitpython.py, code.py, boot.py) are
    deployed to ROOT/flash (lib/ as .mpy for MicroPython, as sources for
    CircuitPython, whose interpreter refuses MicroPython's .mpy); the stand-ins,
    the board's wiring and the link form its ROM (ROOT/rom, on sys.path after the
    flash, as frozen modules are). Power on runs boot.py, then main.py / code.py.
    The firmware's serial line is the child's stdin/stdout; what it prints reaches
    the World's serial (and its pty), what the World receives goes to its stdin,
    each time the firmware waits.
    """

    kind = "board"

    def __init__(self, world, root, interpreter="micropython-float32", heap=None, program=None):
        exe = interpreter_path(interpreter)
        if exe is None:
            raise FileNotFoundError("no %s executable (python -m desktop.firmware.interpreters list)" % interpreter)
        self.runtime = "circuitpython" if interpreter.startswith("circuitpython") else "micropython"
        self.interpreter = interpreter
        self.world = world
        fs = flash_dir(root)
        install_firmware(fs, self.runtime)
        rom = board_rom(os.path.join(root, "rom"), self.runtime)
        to_fw, self._to_fw = os.pipe()
        self._from_fw, from_fw = os.pipe()
        env = board_env(rom, fs, (to_fw, from_fw))
        self.errfile = open(os.path.join(root, "micropython.stderr"), "w+b")
        # program: what runs instead of power-on (a test's snippet on the stand-ins)
        program = program or "import simboard\nsimboard.power_on(%r)\n" % self.runtime
        self.proc = subprocess.Popen([exe, "-X", "heapsize=" + heap_for(interpreter, heap), "-c", program],
                                     cwd=fs, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=self.errfile, pass_fds=(to_fw, from_fw), bufsize=0)
        os.close(to_fw)
        os.close(from_fw)
        out = self.proc.stdout.fileno()
        fcntl.fcntl(out, fcntl.F_SETFL, fcntl.fcntl(out, fcntl.F_GETFL) | os.O_NONBLOCK)
        self.link = HostLink(world, self._read, self._write, on_wait=self._serial)

    def _read(self, n):
        buf = bytearray()
        while len(buf) < n:
            chunk = os.read(self._from_fw, n - len(buf))
            if not chunk:
                self._died()
            buf += chunk
        return bytes(buf)

    def _write(self, data):
        os.write(self._to_fw, data)

    def _serial(self):
        """Move the serial line's bytes: the firmware's output to the World, the World's input to it."""
        while True:
            try:
                data = os.read(self.proc.stdout.fileno(), 65536)
            except BlockingIOError:
                break
            if not data:
                break
            self.world.serial_write(data)
        data = self.world.serial_read()
        if data:
            try:
                self.proc.stdin.write(data)
            except BrokenPipeError:
                pass

    def _died(self):
        self.proc.wait(timeout=5)
        before = len(self.world.out)
        self._serial()           # an uncaught exception's traceback comes out on the serial line
        self.errfile.seek(0)
        err = self.errfile.read().decode(errors="replace") + self.world.out[before:].decode(errors="replace")
        raise DeviceDied("%s exited (%s): %s" % (self.interpreter, self.proc.returncode, err.strip()[-2000:]))

    def close(self):
        if self._stop():
            self.proc.kill()
            self.proc.wait()
        for fd in (self._to_fw, self._from_fw):
            try:
                os.close(fd)
            except OSError:
                pass
        self.errfile.close()
        self.world.close()


def start_device(world, root, kind="micropython", **kw):
    """A running device: kind "cpython" (in-process), an interpreter's name on the simulation
    HAL ("micropython", "micropython-float32", "micropython-reprc", "circuitpython"), or
    "board:NAME", the board's own HAL on stand-ins in interpreter NAME."""
    os.makedirs(root, exist_ok=True)
    if kind == "cpython":
        return InProcessDevice(world, root, **kw)
    if kind.startswith("board:"):
        return BoardDevice(world, root, interpreter=kind[6:], **kw)
    return MicroPythonDevice(world, root, interpreter=kind, **kw)
