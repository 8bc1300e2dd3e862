"""What a surveyor in the field meets around the commands: the version, a pipe closed early, an
extra not installed, no display for a live plot, and `status` finding a running emulator.

Every step a `fluxcal` command in a subprocess, as typed; the emulator is the in-process firmware
(`emulate --runtime cpython`), whose port a command without --port must find. Each test gives the
commands its own runtime folder (XDG_RUNTIME_DIR), so emulators of other tests are not seen.
"""

import json
import os
import signal
import subprocess
import sys
from importlib import metadata

import numpy as np
import pytest

from desktop.cli import EXTRAS
from desktop.firmware.deploy import firmware_version
from shared import codes

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FLUXCAL = os.path.join(os.path.dirname(sys.executable), "fluxcal")


def run(*args, env=None, stdout=subprocess.PIPE):
    return subprocess.run([FLUXCAL, *map(str, args)], stdout=stdout, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                          env=env, timeout=120)


def one_line_error(r):
    """A refusal as the CLI promises it: exit 1, one line `fluxcal: ...`, no traceback."""
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fluxcal: "), r.stderr
    return lines[0]


@pytest.fixture
def runtime_env(tmp_path):
    folder = tmp_path / "run"
    folder.mkdir()
    return dict(os.environ, XDG_RUNTIME_DIR=str(folder))


@pytest.fixture
def emulator(runtime_env):
    emu = subprocess.Popen([FLUXCAL, "emulate", "--runtime", "cpython"], cwd=ROOT, env=runtime_env,
                           stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = emu.stdout.readline()
        assert " on /dev/" in first, first + emu.stderr.read()
        ready = emu.stdout.readline()
        assert ready.startswith("ready:"), ready + emu.stderr.read()
        yield emu, first.split(" on ")[-1].strip()
    finally:
        emu.terminate()
        emu.wait(timeout=60)


def test_version_names_the_package_the_firmware_and_the_protocol():
    r = run("--version")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "fluxcal %s (firmware %s, protocol %s)" % (
        metadata.version("fluxcal"), firmware_version(), codes.PROTOCOL_VERSION)


def _closed_pipe():
    """A pipe whose reader has gone (as `| head -3` once head has its lines): its writing end."""
    r, w = os.pipe()
    os.close(r)
    return w


def test_a_reader_that_goes_away_ends_the_command_quietly():
    w = _closed_pipe()
    try:
        r = run("--version", stdout=w)
    finally:
        os.close(w)
    assert r.returncode == 128 + signal.SIGPIPE and r.stderr == "", r.stderr


def test_status_without_port_finds_the_running_emulator_and_says_so(emulator, runtime_env):
    emu, port = emulator
    r = run("status", env=runtime_env)
    assert r.returncode == 0, r.stderr
    first = r.stdout.splitlines()[0]
    assert "on %s, a virtual handheld (fluxcal emulate, pid %d)" % (port, emu.pid) in first, first
    assert json.loads(run("status", "--json", env=runtime_env).stdout)["port"] == port
    w = _closed_pipe()      # fluxcal status | head -3, the reader gone before status writes
    try:
        r = run("status", env=runtime_env, stdout=w)
    finally:
        os.close(w)
    assert r.returncode == 128 + signal.SIGPIPE and "Traceback" not in r.stderr, r.stderr
    emu.terminate()
    emu.wait(timeout=60)
    assert os.listdir(os.path.join(runtime_env["XDG_RUNTIME_DIR"], "fluxcal")) == []   # it cleaned up
    line = one_line_error(run("status", env=runtime_env))
    assert "fluxcal emulate" in line and port not in line, line    # the hint, not the emulator gone


def test_a_killed_emulator_is_forgotten(runtime_env, tmp_path):
    """An emulator killed without its clean-up leaves its file; a later command does not try it."""
    folder = os.path.join(runtime_env["XDG_RUNTIME_DIR"], "fluxcal")
    os.makedirs(folder)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = os.path.join(folder, "emulate-%s.json" % dead.stdout.strip())
    with open(stale, "w") as fh:
        json.dump({"port": "/dev/null", "pid": int(dead.stdout), "runtime": "cpython"}, fh)
    line = one_line_error(run("status", env=runtime_env))
    assert "/dev/null" not in line and not os.path.exists(stale), line


def test_monitor_plot_without_a_display_says_so_and_a_file_gets_the_plot(emulator, runtime_env, tmp_path):
    pytest.importorskip("matplotlib")
    _emu, port = emulator
    no_display = dict(runtime_env, MPLBACKEND="agg")     # what matplotlib falls back on without a display
    no_display.pop("DISPLAY", None)
    line = one_line_error(run("monitor", "--plot", "--seconds", "1", "--port", port, env=no_display))
    assert "no display" in line and "--plot FILE.png" in line, line
    png = tmp_path / "monitor.png"
    r = run("monitor", "--plot", png, "--seconds", "3", "--port", port, env=no_display)
    assert r.returncode == 0, r.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [f for f in os.listdir(tmp_path) if f.endswith(".tmp.png")]


def test_a_missing_extra_is_one_line_naming_it(tmp_path):
    """report without matplotlib (the plots extra): one line naming the extra, no traceback. The
    module is hidden as an uninstalled one looks to import (None in sys.modules)."""
    rng = np.random.default_rng(1)
    u = rng.normal(size=(300, 3))
    h = 48000.0 * u / np.linalg.norm(u, axis=1, keepdims=True) * [1.01, 0.99, 1.0] + [120.0, -40.0, 75.0]
    csv = tmp_path / "h.csv"
    np.savetxt(csv, h, delimiter=",", header="x,y,z", comments="")
    code = ("import sys; sys.modules['matplotlib'] = None; sys.argv[0] = 'fluxcal'; from desktop.cli import main; "
            "sys.exit(main(sys.argv[1:]))")
    r = subprocess.run([sys.executable, "-c", code, "report", str(csv), "-o", str(tmp_path / "out")],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    line = one_line_error(r)
    assert line == "fluxcal: report needs matplotlib, which is not installed: pip install 'fluxcal[%s]'" % (
        EXTRAS["matplotlib"]), line
