# Runs under the `micropython` executable (data for desktop/bench/core.py, not a module
# of the desktop package): the cost of the calibration core.
# argv: repo root, samples. Prints one JSON line. add_us is process CPU time (time.clock, the
# loop of n adds), beside its wall time add_us_wall: on a shared machine the wall time also
# holds time spent waiting for a core. solve_ms: CPU time of 5 solves of the same sums / 5
# (solve_ms_wall: the median wall time of the 5).
import array
import gc
import json
import math
import sys
import time

sys.path.insert(0, sys.argv[1])
from shared.fit import EllipsoidFit  # noqa: E402

n = int(sys.argv[2])
seed = 1


def rnd():
    global seed
    seed = (seed * 1103515245 + 12345) & 0x7FFFFFFF
    return seed / 2147483648.0


# A distorted sphere in 24-bit ADC codes: |B| = 50,000 nT at 100 codes/nT
# would be 5e6 codes; ADS1292 codes are within +-2^23 = 8.4e6.
pts = array.array("i", [0] * (3 * n))  # the test data, outside the measured state
for k in range(n):
    c = 2 * rnd() - 1
    p = 2 * math.pi * rnd()
    s = math.sqrt(1 - c * c)
    x, y, z = 5e6 * s * math.cos(p), 5e6 * s * math.sin(p), 5e6 * c
    pts[3 * k] = int(1.004 * x + 0.01 * y + 30000 + 50 * rnd())
    pts[3 * k + 1] = int(0.997 * y + 20000 + 50 * rnd())
    pts[3 * k + 2] = int(1.001 * z - 0.015 * x - 10000 + 50 * rnd())

gc.collect()
before = gc.mem_alloc()
fit = EllipsoidFit()
c0 = time.clock()
t0 = time.ticks_us()
for k in range(0, 3 * n, 3):
    fit.add(pts[k], pts[k + 1], pts[k + 2])
t1 = time.ticks_us()
c1 = time.clock()
add_cpu_us = int((c1 - c0) * 1e6)   # a small int; the clock's boxed floats must not count in the state
c0 = c1 = None
gc.collect()
held = gc.mem_alloc() - before
solves = []
results = []
c2 = time.clock()
for _ in range(5):
    t2 = time.ticks_us()
    cal = fit.solve(scale=0.01)
    t3 = time.ticks_us()
    solves.append(time.ticks_diff(t3, t2) / 1000)
    results.append((cal.diagnostics["iterations"], cal.diagnostics.get("rms")))
c3 = time.clock()
solves.sort()
print(json.dumps({
    "add_us": add_cpu_us / n,
    "add_us_wall": time.ticks_diff(t1, t0) / n,
    "solve_ms": (c3 - c2) * 1000 / 5,
    "solve_ms_wall": solves[2],
    "solves_identical": all(r == results[0] for r in results),
    "state_bytes": held,
    "iterations": cal.diagnostics["iterations"],
    "n": n,
}))
