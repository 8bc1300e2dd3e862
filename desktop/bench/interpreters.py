"""The firmware's core on each interpreter a board has: precision against CPython, and speed.

    python -m desktop.bench.interpreters              # markdown table (docs/firmware.md)
    python -m desktop.bench.interpreters --repeats 5

What: micropython-scripts/interp_core.py on the realistic instrument of
desktop/sim/instrument.py (48,000 nT, codes up to 7.6 million): the calibration CPython
fitted, applied to a 360 degree spin of codes in the interpreter (max |delta |B|| against
CPython's own |h_c|, and the bound 4 rounding units of the field that the tests hold it
to; and the survey output's |h_c|, computed in integers by shared/fixedpoint.py, against the
same float64 values); the same 4000 codes fitted there (iterations of the solve, us per add(), ms per
solve()). All interpreters run in the same run, interleaved, R times; timings are the
median (min-max) over the runs, wall time on this shared machine.
Why: the unix builds compute as boards do (float width, 30-bit small ints), so precision is
theirs; their speed is this machine's, for comparison between them only. A board's cost is
the instruction counts of python -m desktop.bench.cortexm.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from desktop.bench.repeat import det, fmt
from desktop.firmware.files import REPO
from desktop.firmware.interpreters import FLOAT_BITS, UNIX, interpreter
from desktop.methods import fit_array, magnitudes
from desktop.sim.instrument import realistic_instrument
from shared.fixedpoint import FRACTION_BITS

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts", "interp_core.py")
WORD = {"micropython": "64-bit", "micropython-float32": "64-bit", "micropython-reprc": "32-bit", "circuitpython": "32-bit"}
FLOAT = {53: "double", 24: "float32", 22: "30-bit (22-bit significand)"}
SURVEY_UNIT = 1000.0 * 2 ** FRACTION_BITS   # the survey's integer |h_c| per nT


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.interpreters", description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    t0 = time.time()
    fit_codes, spin, field = realistic_instrument()
    cal = fit_array(fit_codes.astype(float), field=field)
    want = magnitudes(cal, spin.astype(float))
    runs = {name: [] for name in UNIX}
    missing = [name for name in UNIX if interpreter(name) is None]
    with tempfile.TemporaryDirectory() as tmp:
        job = os.path.join(tmp, "job.json")
        with open(job, "w") as fh:
            json.dump({"cal": cal.to_dict(), "fit": fit_codes.tolist(), "spin": spin.tolist(), "field": field}, fh)
        for _ in range(args.repeats):
            for name in UNIX:
                if name in missing:
                    continue
                r = subprocess.run([interpreter(name), SCRIPT, job, REPO], capture_output=True, text=True, timeout=600)
                if r.returncode:
                    raise RuntimeError("%s: %s" % (name, r.stderr.strip()[-1000:]))
                runs[name].append(json.loads(r.stdout))
    notes = []
    print("### The core on each interpreter (realistic instrument: 48,000 nT, codes to 7.6 million; %d runs)\n"
          % args.repeats)
    print("| interpreter | word | float | max \\|delta \\|B\\|\\| vs CPython, 360 deg spin | bound (4 rounding units"
          " of the field) | survey output's \\|B\\| (integers) vs CPython | solve iterations | add() | solve() |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in UNIX:
        if name in missing:
            print("| %s | not built: make interpreters | | | | | | |" % name)
            continue
        rs = runs[name]
        dev = [float(np.max(np.abs(np.array([float(v) for v in r["magnitude"]]) - want))) for r in rs]
        survey = [float(np.max(np.abs(np.array(r["survey"]) / SURVEY_UNIT - want))) for r in rs]
        bound = 4 * 2.0 ** -FLOAT_BITS[name] * field
        print("| %s | %s | %s | %s nT | %.3g nT | %s nT | %s | %s | %s |" % (
            name, WORD[name], FLOAT[FLOAT_BITS[name]], det(dev, "%.2g", name + " delta", notes), bound,
            det(survey, "%.2g", name + " survey", notes),
            det([r["iterations"] for r in rs], "%d", name + " iterations", notes),
            fmt([r["add_us"] for r in rs], "%.1f", " us"), fmt([r["solve_ms"] for r in rs], "%.1f", " ms")))
    for line in notes:
        print("\nNOTE: " + line)
    print("\n(command: python -m desktop.bench.interpreters --repeats %d; %.0f s)" % (args.repeats, time.time() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
