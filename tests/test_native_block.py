"""A survey block's numbers in C (fitsums.block, device/native/block.h) against the pure-Python way
(device/survey.py Output._numbers: protocol.hundredths, ExactCorrection's integer correction, the
rounded mean |h_c|), integer for integer.

tests/micropython/native_block.py fills the block's words with sums of every width (a real block's,
full-scale codes, past the words' limits and the 64-bit ends, negative |h_c| sums), blocks of 1 to
65,535 samples and windows of 1 to 64, and calls fitsums.block on each interpreter with the
fitsums.mpy deploy would pick for it (x64 on the 64-bit unix builds, x86 on the 32-bit one), on the
emulated Pico (armv6m) and Cortex-M3 (armv7m). fitsums.block must answer every block whose numbers
fit its words (so a native path silently not taken fails), give Python's integers, decline the
rest (survey.py then does them in Python) and leave the words restarted or untouched as asked.
CircuitPython loads no MicroPython .mpy and uses Python's way.
"""

import json
import os

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import (LOADS_NATMODS, _need_natmod, on_the_emulated_cortex_m3,
                                     on_the_emulated_pico, output)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_block.py")
SOURCES = ["shared/" + f for f in sorted(os.listdir(os.path.join(REPO, "shared"))) if f.endswith(".py")] + [
    "device/protocol.py", "tests/micropython/lcg.py"]


def _check(text, native, cases):
    got = json.loads(text.splitlines()[-1])
    assert got["cases"] == cases
    assert got["path"] == ("native" if native else "python")
    if native:
        assert got["expected"] > cases // 4          # a third of the cases fit the words...
        assert got["answered"] == got["expected"]    # ...and C answered each of them
        assert got["missed"] == got["wrongly"] == 0
        assert got["mismatched"] == 0                # with Python's integers
        assert got["untidy"] == 0                    # the words restarted or left as asked
    else:
        assert got["answered"] == 0


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_block_is_pythons(name, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name)
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), name in LOADS_NATMODS, 1500)


def test_native_block_on_the_emulated_pico(tmp_path):
    _check(on_the_emulated_pico(tmp_path, SCRIPT, sources=SOURCES), True, 400)


def test_native_block_on_the_emulated_cortex_m3(tmp_path, mpy_cross):
    _check(on_the_emulated_cortex_m3(tmp_path, SCRIPT, mpy_cross, sources=SOURCES), True, 400)
