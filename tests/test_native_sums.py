"""The native sums (device/native/fitsums.c) against the pure-Python big integers, bit for bit.

tests/micropython/native_sums.py feeds shared.fit.EllipsoidFit the same codes on CPython
(the pure-Python sums: the reference) and on every interpreter a board has, with the
fitsums.mpy deploy would pick for it (desktop.firmware.natmod.natmod_for its _mpy) on the
path (and on the emulated Pico and Cortex-M3, armv6m and armv7m): random codes with a tenth removed, the ±2**23 extremes in every combination and
a long run at full scale (degree-4 sums far past 64 bits), all of it removed again,
codes past the native words' range and bools mixed in, drains mid-stream, a merge.
Every sum must be the same integer. The MicroPython builds must take the native path;
CircuitPython loads no MicroPython .mpy and must fall back to pure Python. A natmod
not built is a skip saying so (a failure under FLUXCAL_REQUIRE_INTERPRETERS).
"""

import json
import os
import shutil
import subprocess
import sys

import pytest

from desktop.firmware.mpy import decode_mpy
from desktop.firmware.natmod import natmod_for
from tests.interpreters import INTERPRETERS, need

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_sums.py")
LOADS_NATMODS = {"micropython", "micropython-float32", "micropython-reprc", "rp2-pico"}


def output(argv):
    """The command's stdout (it must succeed)."""
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr
    return proc.stdout


def _run(argv):
    return json.loads(output(argv).splitlines()[-1])


@pytest.fixture(scope="module")
def reference():
    got = _run([sys.executable, SCRIPT, REPO, ""])
    assert got["path"] == "python"         # CPython never loads a .mpy
    assert set(got["sums"][3]) == {"0"}    # everything added was removed
    return got


def _missing(msg):
    """Skip saying why (fail under FLUXCAL_REQUIRE_INTERPRETERS, as CI sets it)."""
    if os.environ.get("FLUXCAL_REQUIRE_INTERPRETERS"):
        pytest.fail(msg)
    pytest.skip(msg)


def _need_natmod(exe, name, module="fitsums"):
    """The <module>.mpy for the interpreter's _mpy, or skip (fail under FLUXCAL_REQUIRE_INTERPRETERS)."""
    out = subprocess.run([exe, "-c", "import sys; print(sys.implementation._mpy)"], capture_output=True, text=True)
    target = decode_mpy(int(out.stdout.split()[-1]))
    path = natmod_for(target, module)
    return path or _missing("no %s.mpy for %s (%s): make interpreters" % (module, name, target))


def _sources(sources):
    """The repository's .py files the script imports: every file of shared/ by default."""
    if sources is not None:
        return sources
    return ["shared/" + f for f in sorted(os.listdir(os.path.join(REPO, "shared"))) if f.endswith(".py")]


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_sums_equal_the_pure_python_ones(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name)
    got = _run([exe, SCRIPT, REPO, os.path.dirname(natmod)])
    assert got["path"] == ("native" if name in LOADS_NATMODS else "python")
    assert got["sums"] == reference["sums"]
    assert got["refused"] == reference["refused"]      # a float: the same TypeError


def on_the_emulated_pico(tmp_path, script, module="fitsums", sources=None):
    """The armv6m build of `module` on the rp2 firmware (Cortex-M0+, 31-bit small ints): `sources`
    (repository paths; shared/ by default) and `script` as .mpy from the Pico's own mpy-cross, in
    its flash's filesystem at /disk before it boots (tests/pico_flash.py: mpremote's
    copy was a third of a run; not mounted: mount's 1 s poll times out when this machine is
    loaded): what script.main('/disk', '/disk') prints."""
    need("rp2-pico")
    from desktop.devicesim.pico_board import PicoBoard
    from tests.pico_flash import flash_with
    from desktop.firmware.interpreters import pico_parts
    from desktop.firmware.natmod import natmod_path

    modules = (module,) if isinstance(module, str) else module      # one native module, or several
    natmods = [natmod_path("armv6m", m) or _missing("no %s.mpy for armv6m: make interpreters" % m) for m in modules]
    cross = pico_parts()["mpy_cross"]
    name = os.path.basename(script)[:-3]
    for source in _sources(sources):
        out = tmp_path / "disk" / (source[:-3] + ".mpy")
        out.parent.mkdir(parents=True, exist_ok=True)
        subprocess.run([cross, "-o", str(out), os.path.join(REPO, source)], check=True)
    subprocess.run([cross, "-o", str(tmp_path / "disk" / (name + ".mpy")), script], check=True)
    for m, natmod in zip(modules, natmods):
        shutil.copyfile(natmod, tmp_path / "disk" / (m + ".mpy"))
    flash_with(str(tmp_path / "pico.flash"), str(tmp_path / "disk"))
    with PicoBoard(str(tmp_path / "pico.flash")) as board:
        run = "import sys; sys.path.insert(0, '/disk'); import %s; %s.main('/disk', '/disk')" % (name, name)
        return output([sys.executable, "-m", "mpremote", "connect", board.port, "exec", run])


def on_the_emulated_cortex_m3(tmp_path, script, mpy_cross, module="fitsums", sources=None):
    """The armv7m build of `module` on bare-metal MicroPython in qemu (Cortex-M3, 31-bit small ints),
    from the board's ROM filesystem, as tests/test_shared_on_cortexm.py runs shared/ there (`sources`
    in its lib/): what script.main('/rom/lib', '/rom') prints."""
    need("qemu-m3")
    if shutil.which("qemu-system-arm") is None:
        _missing("qemu-system-arm is missing")
    from desktop.devicesim.qemu_board import QemuBoard
    from desktop.firmware.natmod import natmod_path

    natmod = natmod_path("armv7m", module) or _missing("no %s.mpy for armv7m: make interpreters" % module)
    name = os.path.basename(script)[:-3]
    rom = tmp_path / "rom"
    for source in _sources(sources):
        out = rom / "lib" / (source[:-3] + ".mpy")
        out.parent.mkdir(parents=True, exist_ok=True)
        subprocess.run([mpy_cross, "-o", str(out), os.path.join(REPO, source)], check=True)
    subprocess.run([mpy_cross, "-o", str(rom / (name + ".mpy")), script], check=True)
    shutil.copyfile(natmod, rom / (module + ".mpy"))
    with QemuBoard(rom=str(rom)) as board:
        return board.exec("import %s\n%s.main('/rom/lib', '/rom')" % (name, name))


def test_native_sums_on_the_emulated_pico(reference, tmp_path):
    got = json.loads(on_the_emulated_pico(tmp_path, SCRIPT).splitlines()[-1])
    assert got["path"] == "native"
    assert got["sums"] == reference["sums"]
    assert got["refused"] == reference["refused"]


def test_native_sums_on_the_emulated_cortex_m3(reference, tmp_path, mpy_cross):
    got = json.loads(on_the_emulated_cortex_m3(tmp_path, SCRIPT, mpy_cross).splitlines()[-1])
    assert got["path"] == "native"
    assert got["sums"] == reference["sums"]
    assert got["refused"] == reference["refused"]
