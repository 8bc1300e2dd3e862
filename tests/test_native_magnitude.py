"""The survey's native |h_c| (fitsums.magnitude, device/native/fitsums.c) against the pure-Python
ExactCorrection.magnitude (shared/fixedpoint.py), bit for bit.

tests/micropython/native_magnitude.py runs the same corrections and sums on CPython (the pure
method: the reference) and on each interpreter with the fitsums.mpy deploy would pick for it
(the x64 build on the 64-bit unix builds, x86 on the 32-bit one), and on the emulated Pico
(armv6m) and Cortex-M3 (armv7m): realistic and adversarial calibrations (offsets at the ADC's
range, strong cross terms, coefficients near the words' 2**63) over windows of 1 to 64 codes,
sums at the +-2**23 x window corners, random and past the words; then h set exactly (squares at,
one under and one over perfect squares up to 3 * 2**124, h at the 2**62 edge), random numbers
over the words' whole range and every number at its extreme. Every |h_c| must be CPython's
integer, and the same as the pure method's on the interpreter itself. The native function must
answer every call whose numbers and sums fit its words (so a native path silently not taken
fails), and must not be called at all for a correction whose coefficient or offset does not fit
(decided when it is built: its `path` is "python"). The same calls check fitsums.correct (the
block's h_c) and fitsums.survey (device/survey.py's block sums with |h_c|, in words: the sums,
|h_c| and the count after two samples; refused calls change nothing) against the pure methods,
and that each answered every call that fits its words. CircuitPython loads no MicroPython .mpy
and keeps the pure path.
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import (LOADS_NATMODS, _need_natmod, on_the_emulated_cortex_m3,
                                     on_the_emulated_pico, output)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_magnitude.py")
# what the script imports (modulefinder's closure of it): fixedpoint and the random ints
SOURCES = ["shared/__init__.py", "shared/fixedpoint.py", "tests/micropython/lcg.py"]
PATHS = ["real"] * 5 + ["adversarial"] * 3 + ["top"] * 2      # then wide_c and wide_w: always python


def _paths(path):
    return [p + ":" + path for p in PATHS] + ["wide_c:python", "wide_w:python"]


@pytest.fixture(scope="module")
def reference():
    lines = output([sys.executable, SCRIPT, REPO, ""]).splitlines()
    summary = json.loads(lines[-1])
    assert summary["path"] == "python" and summary["paths"] == _paths("python")
    assert summary["mismatched"] == 0
    return lines[:-1]


def _check(text, reference, native):
    lines = text.splitlines()                # (mpremote's own lines first)
    got = json.loads(lines[-1])
    assert lines[-1 - len(reference):-1] == reference       # every |h_c|, as CPython's pure method gives it
    assert got["mismatched"] == 0            # and as the pure method gives it on this interpreter
    assert got["path"] == ("native" if native else "python")
    assert got["paths"] == _paths(got["path"])
    assert got["misfit_calls"] == 0          # a correction that does not fit never calls C
    if native:
        assert got["expected"] > 800         # most calls fit the words...
        assert got["native"] == got["expected"]     # ...and C answered each of them
        # and so did fitsums.correct and fitsums.survey (hc.h), with the same integers
        assert got["correct"] == got["correct_expected"] > 300     # (|h_c| under 2**30 milli-nT)
        assert got["survey"] == got["survey_expected"] > 600      # (|h_c| under 2**47)
    else:
        assert got["correct"] == got["survey"] == 0
    return got


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_magnitude_is_the_pure_python_one(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name)
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), reference, name in LOADS_NATMODS)


def test_native_magnitude_on_the_emulated_pico(reference, tmp_path):
    _check(on_the_emulated_pico(tmp_path, SCRIPT, sources=SOURCES), reference, True)


def test_native_magnitude_on_the_emulated_cortex_m3(reference, tmp_path, mpy_cross):
    _check(on_the_emulated_cortex_m3(tmp_path, SCRIPT, mpy_cross, sources=SOURCES), reference, True)
