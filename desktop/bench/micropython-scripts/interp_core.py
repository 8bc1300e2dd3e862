# Runs under each interpreter (desktop/bench/interpreters.py): argv[1] a JSON job
# {"cal": calibration dict, "fit": [[x, y, z], ...], "spin": [[x, y, z], ...]}, argv[2] the
# repository root. Fits job["fit"] (add() timed per call), solves it (timed), and prints one
# JSON line: us per add, ms per solve, its iterations, and Calibration.magnitude of every
# spin code under job["cal"] (the calibration CPython fitted) as repr strings, and the
# survey's integer |h_c| of each (shared/fixedpoint.py: 1/256 milli-nT).
import json
import sys
import time

sys.path.insert(0, sys.argv[2])
from shared.calibration import Calibration  # noqa: E402
from shared.fit import EllipsoidFit  # noqa: E402
from shared.fixedpoint import ExactCorrection  # noqa: E402

try:
    ticks_us, ticks_diff = time.ticks_us, time.ticks_diff
except AttributeError:      # CircuitPython: no ticks_us on the unix port
    def ticks_us():
        return time.monotonic_ns() // 1000

    def ticks_diff(a, b):
        return a - b

with open(sys.argv[1]) as fh:
    job = json.load(fh)
points = job["fit"]
fit = EllipsoidFit()
t0 = ticks_us()
for x, y, z in points:
    fit.add(x, y, z)
add_us = ticks_diff(ticks_us(), t0) / len(points)
t0 = ticks_us()
cal = fit.solve(field=job["field"])
solve_ms = ticks_diff(ticks_us(), t0) / 1000
ref = Calibration.from_dict(job["cal"])
exact = ExactCorrection(ref, 1)
print(json.dumps({"add_us": add_us, "solve_ms": solve_ms, "iterations": cal.diagnostics["iterations"],
                  "magnitude": [repr(ref.magnitude(x, y, z)) for x, y, z in job["spin"]],
                  "survey": [exact.magnitude(x, y, z) for x, y, z in job["spin"]]}))
