"""The DRDY handler as a hard IRQ runs it, on every interpreter: heap locked, so any
allocation raises MemoryError. On the 32-bit builds a small int ends at 2**30 - 1; every
counter and accumulator starts just below its wrap point and full-scale frames fill the
largest boxcar, so a counter that builds 2**30 before masking, or a sum past 2**30, fails."""

import json
import os
import subprocess

import pytest

from tests.interpreters import INTERPRETERS, need

SCRIPT = os.path.join(os.path.dirname(__file__), "micropython", "isr_wrap.py")


@pytest.mark.parametrize("name", INTERPRETERS)
def test_handler_wraps_its_counters_without_allocating(name, root):
    proc = subprocess.run([need(name), SCRIPT, root], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["errors"] == []
    top = (1 << 30) - 1
    frames = 3 * 64                                   # three blocks of MAX_WINDOW = decim = 64 frames
    assert out["frames"] == (top - 2 + frames) % (1 << 30)
    assert out["blocks"] == (top - 2 + 3) % (1 << 30)
    full = 64 * ((1 << 23) - 1)                       # the largest boxcar sum: under 2**29
    assert out["samples"] == [[full] * 4] * 3


def test_the_button_s_interrupt_allocates_nothing_on_the_emulated_pico(tmp_path):
    """hal_micropython's button handler (a hard IRQ on the pin) with the heap locked on the rp2
    firmware, and the closing it records taken once by button_edge (device/button.py)."""
    from tests.test_native_sums import on_the_emulated_pico
    script = os.path.join(os.path.dirname(__file__), "micropython", "button_irq.py")
    sources = ["shared/__init__.py", "shared/codes.py", "device/config.py", "device/hal.py", "device/hal_micropython.py"]
    out = json.loads(on_the_emulated_pico(tmp_path, script, module="drdy", sources=sources).splitlines()[-1])
    assert out["edges"] is True and out["errors"] == [], out
    assert 0 <= out["taken"] <= 2 and out["again"] == 0, out
