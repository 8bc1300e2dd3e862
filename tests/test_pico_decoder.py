"""The emulated Pico's faster decoder (desktop/devicesim/pico/decoder.mjs) is rp2040js's own core,
instruction for instruction: tests/pico/decoder_check.mjs checks the branch every opcode takes,
then boots the rp2 firmware on two chips, one with each core, types the same Python at both
REPLs and compares PC, registers, flags, cycles and emulated time after every instruction, and
SRAM and the USB output at the end. What the Python printed is CPython's (float32 for the float).
"""

import json
import math
import os
import subprocess

from tests.interpreters import need

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CHECK = os.path.join(ROOT, "tests", "pico", "decoder_check.mjs")
STEPS = 40_000_000        # boot (~30 M) and the snippet: about 0.6 s of the emulated Pico
SNIPPET = "import math; print(sum(i*i for i in range(3000)) * 7**40, math.sin(1.25) * 3.5e7, 2**-140, 10 // 3 - 7 % -3)"


def test_the_indexed_decoder_runs_the_firmware_as_the_stock_core():
    need("rp2-pico")
    from desktop.firmware.interpreters import pico_parts

    parts = pico_parts()
    r = subprocess.run(["node", CHECK, parts["node_modules"], parts["firmware"], parts["bootrom"], str(STEPS), SNIPPET],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert got["branches"] > 80 and got["opcodes"] > 65536, got      # every opcode, every branch
    assert got["wrong"] == 0, got
    assert got["steps"] == STEPS and got["differed"] == 0, got        # in step the whole way
    assert got["sram_same"] and got["usb_same"] and got["typed"], got
    printed = got["out"].split("\r\n")[-2].split()
    assert int(printed[0]) == sum(i * i for i in range(3000)) * 7 ** 40, printed
    assert math.isclose(float(printed[1]), math.sin(1.25) * 3.5e7, rel_tol=2 ** -23), printed   # float32
    assert float(printed[2]) == 0.0 and printed[3] == "5", printed   # 2**-140: flushed to 0 by the ROM's floats
