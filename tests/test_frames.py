"""App.step and its per-pass calls that fit keep their frames on the C stack (device/app.py, Frames).

MicroPython without a Python stack (the rp2 port) takes a called function's frame from the heap
when its state passes 11 words (py/objfun.c VM_MAX_STATE_ON_STACK: locals and value stack a word
each, two more per active try). On the firmware's fragmented heap such a frame, alive while the
pass allocates, made the whole firmware a third busier (App.step at 14 words: 17.2 -> 23.6 %
calibrating on the emulated Pico). Each function's state is read from what the rp2 firmware's own
mpy-cross makes of the module (the prelude's n_state and n_exc_stack, tools/mpy-tool.py).
"""

import glob
import os
import re
import subprocess
import sys

import pytest

from desktop.firmware.interpreters import BUILD
from tests.interpreters import need

DEVICE = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "device")
STACK_BYTES = 11 * 4      # VM_MAX_STATE_ON_STACK on a 32-bit port
# module: the functions run every main-loop pass (app.py run/step), by qualified name; each of
# Protocol.poll, Board.serial_read, Led.update and Health.check keeps its usual path (nothing
# waiting, nothing due) in a frame of its own and the rest in a method it calls
PER_PASS = {
    "app.py": ["App.step", "App.wait", "App._pass_ms"],
    "button.py": ["Button.poll", "Button.due_ms"],
    "led.py": ["Led.due_ms", "Led.update"],
    "health.py": ["AdcSupervisor.check", "Health.check"],
    "protocol.py": ["Protocol.poll"],
    "hal_micropython.py": ["Board.serial_read"],
    "bootguard.py": ["Guard.passed"],
    "calibration_flow.py": ["CalibrationFlow.tick"],
}


def frames(path, tmp_path):
    """{qualified name: state bytes} of every function in the module at `path`."""
    mpy_cross = os.path.join(os.path.dirname(need("rp2-pico")), "mpy-cross")
    tools = glob.glob(os.path.join(BUILD, "src", "micropython-*-rp2", "tools", "mpy-tool.py"))
    if not tools:
        pytest.skip("the rp2 port's source (tools/mpy-tool.py) is not unpacked under build/interpreters/src")
    out = os.path.join(str(tmp_path), os.path.basename(path)[:-3] + ".mpy")
    subprocess.run([mpy_cross, "-march=armv6m", "-o", out, path], check=True)
    dump = subprocess.run([sys.executable, tools[0], "-d", out], capture_output=True, text=True, check=True).stdout
    # the raw codes in pre-order, each with its children's names: rebuild the nesting
    codes = []
    for m in re.finditer(r"^simple_name: (\S+)$(.*?)^  children: \[(.*?)\]$", dump, re.M | re.S):
        prelude = re.search(r"^  prelude: \((\d+), (\d+),", m.group(2), re.M)
        n_children = len([c for c in m.group(3).split(",") if c.strip()])
        codes.append((m.group(1), int(prelude.group(1)) * 4 + int(prelude.group(2)) * 8, n_children))
    found = {}
    pos = 0

    def walk(prefix):
        nonlocal pos
        name, size, n = codes[pos]
        pos += 1
        qual = name if not prefix else prefix + "." + name
        found[qual] = size
        for _ in range(n):
            walk(qual)
    walk("")
    return {k.split(".", 1)[1]: v for k, v in found.items() if "." in k}


@pytest.mark.parametrize("module", sorted(PER_PASS))
def test_a_pass_s_calls_keep_their_frames_on_the_c_stack(module, tmp_path):
    got = frames(os.path.join(DEVICE, module), tmp_path)
    for name in PER_PASS[module]:
        assert name in got, "%s: no %s (functions: %s)" % (module, name, sorted(got))
        assert got[name] <= STACK_BYTES, "%s %s: %d B of state, over the %d B a frame on the C stack has" % (
            module, name, got[name], STACK_BYTES)
