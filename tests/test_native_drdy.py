"""The native DRDY handler (drdy.Handler, device/native/drdy.c) against the pure-Python one
(Acquisition._isr, device/acquisition.py), bit for bit, and without allocating.

tests/micropython/native_drdy.py feeds the same conversions to both handlers on each
interpreter with the drdy.mpy deploy would pick for it (the x64 build on the 64-bit unix
builds, x86 on the 32-bit one), and on the emulated Pico (armv6m) and Cortex-M3 (armv7m):
random frames and the +-2**23 codes, bad status headers on either chip, counters near the
2**30 wrap, a small ring that fills and overflows, polled gaps (account_gap), a change of
boxcar mid-run, decim/window with window == decim and window 1; and a board that counts the
conversions before the window (hal.Board.count_drdy, rp2's PIO counter), where both handlers run
on the window's alone and must then hold what a handler fed every conversion holds (the same
samples, FRAMES across the wrap). After every conversion the two
handlers' state, acc and ring arrays and their calls on the bus must be the same, and the
final arrays and a checksum of every intermediate one the same as CPython's pure-Python
handler gives (on the emulated boards every scenario half as long, against CPython's run of
the same). The native handler must be the one attached where the module loads (a native
path silently not taken fails), and must run three boxcars of full-scale frames across every
counter's wrap with the heap locked, as a hard IRQ runs it. CircuitPython loads no MicroPython
.mpy and keeps the pure-Python handler.
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod, on_the_emulated_cortex_m3, on_the_emulated_pico, output

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_drdy.py")
SOURCES = ["device/acquisition.py", "tests/micropython/lcg.py"]
FULL_SCALE_FRAMES = ((1 << 30) - 1 - 2 + 3 * 64) % (1 << 30)     # FRAMES after the heap-locked run


def _reference(*short):
    lines = output([sys.executable, SCRIPT, REPO, ""] + list(short)).splitlines()
    summary = json.loads(lines[-1])
    assert summary == {"path": "python", "differed": 0, "heap_locked": None}
    return lines[:-1]


@pytest.fixture(scope="module")
def reference():
    return _reference()


@pytest.fixture(scope="module")
def board_reference():
    """The emulated boards run every scenario half as long (native_drdy.main's short)."""
    return _reference("short")


def _check(text, reference, native):
    lines = text.splitlines()                # (mpremote's own lines first)
    got = json.loads(lines[-1])
    assert lines[-1 - len(reference):-1] == reference      # every scenario as CPython's handler runs it
    assert got["path"] == ("native" if native else "python")
    assert got["differed"] == 0              # the two handlers, conversion by conversion
    if native:
        assert got["heap_locked"] == [[], True, FULL_SCALE_FRAMES]
    return got


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_drdy_is_the_pure_python_one(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name, "drdy")
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), reference, name in LOADS_NATMODS)


def test_native_drdy_on_the_emulated_pico(board_reference, tmp_path):
    _check(on_the_emulated_pico(tmp_path, SCRIPT, "drdy", SOURCES), board_reference, True)


def test_native_drdy_on_the_emulated_cortex_m3(board_reference, tmp_path, mpy_cross):
    _check(on_the_emulated_cortex_m3(tmp_path, SCRIPT, mpy_cross, "drdy", SOURCES), board_reference, True)
