"""The spike screen (device/screen.py) equals the screen as first written, verdict for verdict.

tests/micropython/screen_same.py runs both on the same streams (a turning field with noise,
one-sample spikes of every size, steps, reversals, random codes and the +-2**23 extremes)
and compares every verdict, accepted sample, counter and the learnt typical bend. The faster
screen skips the bend |v|^2 / |h| where it cannot change the verdict; whether that holds
depends on the float arithmetic, so it runs on CPython and on every interpreter a board has.
"""

import json
import os
import subprocess
import sys

import pytest

from tests.interpreters import INTERPRETERS, need

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "screen_same.py")


def _run(argv):
    proc = subprocess.run(argv + [SCRIPT, REPO], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr
    lines = [json.loads(ln) for ln in proc.stdout.splitlines()]
    assert sum(c["spikes"] for c in lines[:-1]) > 100    # the streams make the screen work
    return lines[-1]


def test_screen_equals_the_reference_on_cpython():
    got = _run([sys.executable])
    assert got["same"], got


@pytest.mark.parametrize("name", INTERPRETERS)
def test_screen_equals_the_reference_on(name, micropython):
    exe = micropython if name == "micropython" else need(name)
    got = _run([exe])
    assert got["same"], got
