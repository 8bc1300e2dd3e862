"""The calibration's disturbance gate (device/gates.py) with the exact |h_c| in C takes the samples
the float |h_c| takes.

tests/micropython/gates_native.py turns a sensor slowly over the sphere with a 300 nT disturbance in
the middle and gates it against a provisional calibration twice: as use_provisional sets it up (the
exact |h_c| of shared/fixedpoint.py in C where the interpreter loads fitsums.mpy) and made to take
the float |h_c|. On every interpreter, the emulated Pico included, both must take the same samples
and reject the same ones, the native path must be taken where fitsums.mpy loads (so a path
silently not taken fails), and the samples taken must be CPython's.
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod, on_the_emulated_pico, output

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "gates_native.py")
DEVICE = ["device/gates.py", "device/residuals.py", "device/config.py", "device/ads1292.py"]


@pytest.fixture(scope="module")
def reference():
    got = json.loads(output([sys.executable, SCRIPT, REPO, ""]).splitlines()[-1])
    assert got["path"] == "python" and got["same"]
    # the disturbance was gated, and its onset taken out again: the test sees the gate work
    assert got["counts"]["rej_dist"] >= 120 and got["counts"]["removed"] > 0, got
    return got


def _check(text, reference, native):
    got = json.loads(text.splitlines()[-1])
    assert got["path"] == ("native" if native else "python")
    assert got["same"], got                          # the exact and the float |h_c| gate alike
    assert (got["checksum"], got["counts"]) == (reference["checksum"], reference["counts"])


@pytest.mark.parametrize("name", INTERPRETERS)
def test_the_exact_gate_takes_what_the_float_gate_takes(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name)
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), reference, name in LOADS_NATMODS)


def test_the_exact_gate_on_the_emulated_pico(reference, tmp_path):
    shared = ["shared/" + f for f in sorted(os.listdir(os.path.join(REPO, "shared"))) if f.endswith(".py")]
    _check(on_the_emulated_pico(tmp_path, SCRIPT, sources=shared + DEVICE), reference, True)
