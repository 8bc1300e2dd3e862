"""The native calibration gates (gatesc.Sample, device/native/gatesc.c) against the pure-Python
Gates.sample (device/gates.py), sample for sample.

tests/micropython/native_gatesc.py feeds the same sums to Gates with the native sample and to
Gates(native=False) on each interpreter with the gatesc.mpy deploy would pick for it (x64 on the
64-bit unix builds, x86 on the 32-bit one; CircuitPython loads none and runs the Python twice)
and on the emulated Pico (armv6m, with fitsums.mpy as deploy puts them together): a smooth turn
filling cells to their cap, a hand's turns at a slow gate (rate rejections, breaks in the
chain), random sums, the cells' boundaries and the +-2**23 extremes, shifted sums past the C
words, sums past a 32-bit port's small ints and 2**31, a provisional calibration with a
disturbance (a step, and one that falls off slowly: back-off and hold), the tau sums attached. After every sample the verdicts and
state must be the same, after each scenario the counts, hist, fit and batches, and each
scenario's checksum CPython's. The native sample must be the one Gates gets where the module
loads and must take the common samples itself, the disturbance gate's included (a path silently
not taken fails): it hands to Python only what the reference alone does (the back-off, sums past
its words, the tau sums), and it allocates nothing for a sample it takes with the disturbance gate
on (heap_lock).
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod, on_the_emulated_pico, output

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_gatesc.py")
SOURCES = ["device/gates.py", "device/residuals.py", "device/config.py", "device/ads1292.py",
           "tests/micropython/lcg.py", "tests/micropython/gates_native.py"]
# the scenarios whose every sample goes to Python (sums past the words, the tau sums attached), and
# those with a disturbance, whose third outlier does (Gates._backoff: once each)
ALL_PYTHON = {8, 10}
BACKOFF = {9, 11}


def _reference(*short):
    lines = output([sys.executable, SCRIPT, REPO, ""] + list(short)).splitlines()
    assert json.loads(lines[-1]) == {"path": "python", "differed": 0, "slow": [None] * 12, "heap_locked": None}
    scenarios = [json.loads(ln) for ln in lines[:-1]]
    # every gate at work: rate, cap and disturbance rejections, samples taken and removed
    assert all(sum(s[k] for s in scenarios) > 100 for k in (2, 3, 6))
    assert all(scenarios[s][4] > 100 and scenarios[s][5] > 0 for s in BACKOFF)
    return lines[:-1]


@pytest.fixture(scope="module")
def reference():
    return _reference()


@pytest.fixture(scope="module")
def board_reference():
    """The emulated Pico runs every stream a quarter as long, a third of the edges, the disturbed
    ones from sample 1300 to 1900 (native_gatesc.py SHORT_FLOATS), and its integer scenarios
    through the native gates alone: their checksums of every verdict and state are these."""
    return _reference("short")


def _check(text, reference, native, short=False):
    lines = text.splitlines()                # (mpremote's own lines first)
    got = json.loads(lines[-1])
    assert lines[-1 - len(reference):-1] == reference      # every scenario as CPython's gates run it
    assert got["path"] == ("native" if native else "python")
    assert got["differed"] == 0              # the two gates, sample for sample
    if native:
        seen = [json.loads(ln)[1] for ln in reference]
        slow = got["slow"]
        for s, n in enumerate(slow):
            if s in ALL_PYTHON:
                assert n == seen[s], (s, slow)
            elif s in BACKOFF:
                assert n == 1, (s, slow)
            elif s == 7:                     # the centre puts about half the shifted sums past 2**15
                assert 0 < n < seen[s], slow
            else:
                assert n == 0, (s, slow)     # all in C
        # no allocation a sample: the gates, the exact |h_c|, fit.add, the count, the hist
        assert got["heap_locked"] == [[], 20, True]
    return got


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_gates_are_the_pure_python_ones(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name, "gatesc")
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), reference,
           name in LOADS_NATMODS)


def test_native_gates_on_the_emulated_pico(board_reference, tmp_path):
    shared = ["shared/" + f for f in sorted(os.listdir(os.path.join(REPO, "shared"))) if f.endswith(".py")]
    _check(on_the_emulated_pico(tmp_path, SCRIPT, ("gatesc", "fitsums"), shared + SOURCES), board_reference, True)
