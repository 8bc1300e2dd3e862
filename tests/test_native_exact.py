"""The solver's native kernels (device/native/exact.h, in fitsums.mpy) against the pure-Python
integers, bit for bit, on every interpreter.

tests/micropython/native_exact.py re-centres random and adversarial sums (up to 250 bits, at the
320-bit words' edges, products that pass them; centres on one axis, past 32-bit small ints, past
64 bits), evaluates Problem.exact on them and converts every sum to floats, through the native
words where they fit (shared.solvewords) and through shared.moments / shared.quadric's ints.
Then it solves two fits (a full sphere, a 40 % cap), each a full solve and a quick
re-calibration, with the kernels and without them. The integers must equal CPython's on every
interpreter, the words' floats the ints' floats, and each interpreter's calibrations with the
kernels its calibrations without them, to the last bit (floats differ between interpreters
of different float widths, never between the two paths of one).
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod, on_the_emulated_pico, output

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_exact.py")


def _parse(text):
    lines = [json.loads(ln) for ln in text.splitlines() if ln.startswith(("[", "{"))]
    return lines[:-1], lines[-1]


@pytest.fixture(scope="module")
def reference():
    ints, got = _parse(output([sys.executable, SCRIPT, REPO, ""]))
    assert got["path"] == "python"         # CPython never loads a .mpy
    assert len(ints) == 60
    return ints, got


def _check(ints, got, reference, native):
    assert got["path"] == ("native" if native else "python")
    assert ints == reference[0]                     # the same integers everywhere
    assert got["bad"] == []                         # words == ints, floats == floats
    assert got["same"] == [True, True]              # the calibrations with and without the kernels
    if native:     # both paths taken: the words (in C) and, past them, the ints
        assert 15 <= got["count"]["recentre"] <= 45 and 15 <= got["count"]["exact"] <= 105


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_exact_equals_the_pure_python(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name)
    ints, got = _parse(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]))
    _check(ints, got, reference, name in LOADS_NATMODS)


def test_native_exact_on_the_emulated_pico(reference, tmp_path):
    ints, got = _parse(on_the_emulated_pico(tmp_path, SCRIPT))
    _check(ints, got, reference, True)
