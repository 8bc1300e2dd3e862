"""shared/ on a microcontroller's instruction set: bare-metal MicroPython on an emulated
Cortex-M3 (desktop/devicesim/qemu_board.py), driven by mpremote as a board is.

The core equivalence check of tests/test_shared_on_micropython.py, there: the same power
sums digit for digit, the solver's fixed point on the same integers, |h_c| within a few
single-precision rounding units of the field. The board computes with software floats
and 31-bit small ints, and runs the .mpy files from its ROM filesystem as frozen
modules. (Its instruction counts are the benchmark's business: python -m desktop.bench.cortexm.)
"""

import json
import os
import shutil
import sys

import numpy as np
import pytest

from desktop.devicesim.qemu_board import QemuBoard
from desktop.firmware.interpreters import mpy_cross_exe
from desktop.methods import magnitudes
from shared.calibration import Calibration
from tests.interpreters import float_eps, need
from tests.scenarios import FIELD, LSB, scenario
from tests.test_shared_on_micropython import CASES, SCRIPT, job_for, run

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ON_BOARD = (0, 1, 2)     # uniform, tumble with a known field, 40 % cap


def _compile(src, out):
    import subprocess
    os.makedirs(os.path.dirname(out), exist_ok=True)
    subprocess.run([mpy_cross_exe(), "-o", out, src], check=True)


@pytest.fixture(scope="module")
def board(tmp_path_factory):
    need("qemu-m3")
    if shutil.which("qemu-system-arm") is None:
        pytest.skip("qemu-system-arm is missing") if not os.environ.get("FLUXCAL_REQUIRE_INTERPRETERS") \
            else pytest.fail("qemu-system-arm is missing")
    rom = tmp_path_factory.mktemp("rom")
    for name in os.listdir(os.path.join(REPO, "shared")):
        if name.endswith(".py"):
            _compile(os.path.join(REPO, "shared", name), str(rom / "lib" / "shared" / (name[:-3] + ".mpy")))
    _compile(SCRIPT, str(rom / "run_fit.mpy"))
    jobs = {}
    for i in ON_BOARD:
        case = CASES[i]
        raw, _, sphere = scenario(case["seed"], case["kind"], coverage=case["coverage"], n=1500, noise=case["noise"])
        jobs[i] = (job_for(raw, case["field"]), raw, sphere)
        (rom / ("job%d.json" % i)).write_text(json.dumps(jobs[i][0]))
    with QemuBoard(rom=str(rom)) as b:
        yield b, jobs


@pytest.mark.parametrize("case", ON_BOARD, ids=[CASES[i]["kind"] + str(CASES[i]["coverage"]) for i in ON_BOARD])
def test_cortex_m3_reaches_cpythons_fixed_point(case, board, root, tmp_path):
    b, jobs = board
    job, raw, sphere = jobs[case]
    got = json.loads(b.exec("import run_fit\nrun_fit.main('/rom/job%d.json', '/rom/lib')" % case).splitlines()[-1])
    cp = run(sys.executable, job, root, tmp_path)
    assert got["sums"] == cp["sums"]
    assert got["state"] == cp["state"]
    a, c = (Calibration.from_dict(r["calibration"]).scaled_input(LSB) for r in (got, cp))
    for h in (raw, sphere):
        assert np.max(np.abs(magnitudes(a, h) - magnitudes(c, h))) <= 4 * float_eps("qemu-m3") * FIELD
