"""The native de-lag (delagc.Push, device/native/delagc.c) against the pure-Python one
(Delag.push, shared/delag.py), bit for bit, and without allocating.

tests/micropython/native_delag.py pushes the same samples through a Delag with the native push and
one with native=False on each interpreter with the delagc.mpy deploy would pick for it (the x64
build on the 64-bit unix builds, x86 on the 32-bit one), and on the emulated Pico (armv6m) and
Cortex-M3 (armv7m): a turning field with noise, steps and gaps, random sums over the whole range,
the +-2**23 * window extremes in every combination (saturation), taus from 1 us to past the native
words, tau steps on and off, set_taus switching mid-stream, and coefficients, limits, the saturation
count and held sums set past the words or a small int; windows 1 .. 64, decimations 1 .. 256, rates
125 .. 8000. After every push the two de-lags' results, outputs, counts and state must be the same,
and each scenario's checksum the same as CPython's pure-Python de-lag gives (on the emulated boards
every stream is shorter, against CPython's run of the same lengths). The native push must be the one
a Delag gets where the module loads (a native path silently not taken fails), must handle a smooth
stream itself (only the four pushes filling the history go to Python) and most of the adversarial
ones, and must run a smooth stream with tau steps with the heap locked. CircuitPython loads no
MicroPython .mpy and keeps the pure-Python push.
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod, on_the_emulated_cortex_m3, on_the_emulated_pico, output

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_delag.py")
SOURCES = ["shared/__init__.py", "shared/delag.py", "tests/micropython/lcg.py"]


def _reference(*short):
    lines = output([sys.executable, SCRIPT, REPO, ""] + list(short)).splitlines()
    summary = json.loads(lines[-1])
    assert summary == {"path": "python", "differed": 0, "slow": None, "heap_locked": None, "handed": None,
                       "pushes": summary["pushes"]}
    scenarios = [json.loads(ln) for ln in lines[:-1]]
    assert scenarios[0][2] == 0                                  # the smooth stream never saturates
    assert sum(s[2] for s in scenarios) > 500                   # the extremes do (985 in the short run)
    return lines[:-1]


@pytest.fixture(scope="module")
def reference():
    return _reference()


@pytest.fixture(scope="module")
def board_reference():
    """The emulated boards run every scenario shorter (native_delag.sizes: at a few MHz of
    emulation the whole run took 80 s on the Pico)."""
    return _reference("short")


def _check(text, reference, native):
    lines = text.splitlines()                # (mpremote's own lines first)
    got = json.loads(lines[-1])
    assert lines[-1 - len(reference):-1] == reference      # every scenario as CPython's de-lag runs it
    assert got["path"] == ("native" if native else "python")
    assert got["differed"] == 0              # the two de-lags, push by push
    if native:
        assert got["slow"] == 4              # a smooth stream: only the four filling the history in Python
        assert got["handed"] < got["pushes"] // 4     # the adversarial streams mostly in C too
        assert got["heap_locked"] == [[], True]
    return got


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_delag_is_the_pure_python_one(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name, "delagc")
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), reference, name in LOADS_NATMODS)


def test_native_delag_on_the_emulated_pico(board_reference, tmp_path):
    _check(on_the_emulated_pico(tmp_path, SCRIPT, "delagc", SOURCES), board_reference, True)


def test_native_delag_on_the_emulated_cortex_m3(board_reference, tmp_path, mpy_cross):
    _check(on_the_emulated_cortex_m3(tmp_path, SCRIPT, mpy_cross, "delagc", SOURCES), board_reference, True)
