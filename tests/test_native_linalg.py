"""The solver's native float kernels (linalgc.mpy, device/native/linalgc.c, installed by shared/linalg_native.py)
against the Python they stand in for, bit for bit, on every interpreter that loads them, and the calibrations
they make the same to the bit.

tests/micropython/native_linalg.py calls each kernel through the native module and with it switched off, on the
same inputs: shared/linalg.py's cholesky, cho_solve, solve_spd and eigh3 (random and badly scaled symmetric
positive definite matrices of 1 to 12 rows, indefinite and singular ones, zero divisors, nearly diagonal and
overflowing 3x3 ones), shared/quadric.py's normal_matrix, shared/iteration.py's add_prior, shared/prior.py's
Prior.residuals (the physical prior and a previous calibration's), shared/predicted.py's _sphere_gradients,
_variance_sum and _bias_spread (random, zeros of both signs, overflowing), shared/moments.py's to_float (ints
of every size and sign, past the module's table of powers, bools) and shared/quadric.py's Problem.sums_at and
Problem.exact in 512-bit words (tests/micropython/exact_cases.py: centres and quadrics of 0 to 70 bits, sums up
to past 2**500 where the module must decline, the sums of random points of 0 to 63 bits), and what the module must hand back to
Python (ints, nan, inf, tuples, ragged rows, 13 rows, a None where a sum is read, a quick fit's directions); then
whole solves of a distorted sphere: every result the same bits and every exception the same. Where the module
loads: the 64-bit unix builds (x64; the pip micropython's doubles, kind "d", the float32 build's binary32, "f")
and the emulated Pico (armv6m, whose ROM floats flush subnormal results to zero: the module does the same there)
and Cortex-M3 (armv7m). The 30-bit-float build (micropython-reprc, x86) loads it but kind() is None: everything
runs in Python. CircuitPython loads no MicroPython .mpy. A native path silently not taken fails (`answered`: the
calls the module answered itself).
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod, on_the_emulated_cortex_m3, on_the_emulated_pico, output

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_linalg.py")
SOURCES = sorted("shared/" + f for f in os.listdir(os.path.join(REPO, "shared")) if f.endswith(".py")) + [
    "tests/micropython/lcg.py", "tests/micropython/exact_cases.py", "desktop/bench/micropython-scripts/cortexm_core.py"]
# the float the module works in where it loads: the interpreter's own; None: it declines (30-bit floats)
KIND = {"micropython": "d", "micropython-float32": "f", "micropython-reprc": None, "rp2-pico": "f"}


def _check(text, kind):
    got = json.loads(text.splitlines()[-1])
    assert got["differed"] == 0, got         # native and Python, call by call
    assert got["solves_differed"] == [], got  # whole calibrations to the bit
    assert got["compared"] > 60
    assert got["kind"] == kind
    assert got["path"] == ("python" if kind is None else "native")
    assert got["to_float"] == got["path"]
    if kind is None:
        assert got["answered"] == 0
    else:
        # most calls answered in C (the rest handed back on purpose: ints, nan, raises), the solves' too,
        # and the exact integer kernels among them (a trial state's sums and its g_A, T, RSS)
        assert got["answered"] > got["compared"]
        assert got["answered_exact"] > 40, got
        assert got["declined_malformed"] is True, got     # tables it is never handed: None, no crash
    return got


def test_cpython_runs_the_python_alone():
    got = json.loads(output([sys.executable, SCRIPT, REPO, ""]).splitlines()[-1])
    assert (got["path"], got["answered"], got["differed"], got["solves_differed"]) == ("python", 0, 0, [])


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_linalg_is_the_pure_python_one(name, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name, "linalgc")
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), KIND.get(name) if name in LOADS_NATMODS else None)


def test_native_linalg_on_the_emulated_pico(tmp_path):
    _check(on_the_emulated_pico(tmp_path, SCRIPT, "linalgc", SOURCES), "f")


def test_native_linalg_on_the_emulated_cortex_m3(tmp_path, mpy_cross):
    _check(on_the_emulated_cortex_m3(tmp_path, SCRIPT, mpy_cross, "linalgc", SOURCES), "f")


@pytest.mark.parametrize("free_needed, path", [(None, "native"), (1 << 40, "python")])
def test_the_firmware_takes_the_kernels_only_with_room_for_them(free_needed, path, micropython):
    """device/app.py's float_kernels at boot: linalgc is imported where the heap has _KERNELS_FREE free, else not,
    and a session's shared/linalg_native.install() uses it only where it is in sys.modules: elsewhere
    shared/linalg.py runs its Python and the module is never loaded (16.8 KB an import on rp2, kept)."""
    natmod = _need_natmod(micropython, "micropython", "linalgc")
    code = ("import sys\nsys.path[:0] = [%r, %r, %r]\nimport app\n" % (os.path.dirname(natmod), os.path.join(REPO, "device"), REPO)
            + ("app._KERNELS_FREE = %d\n" % free_needed if free_needed else "")
            + "print(app.float_kernels())\nfrom shared import linalg_native\nprint(linalg_native.install())\n")
    said, installed = output([micropython, "-c", code]).split("\n")[:2]
    assert said == path
    assert installed == str(path == "native")    # a session's install finds them only where boot imported them
