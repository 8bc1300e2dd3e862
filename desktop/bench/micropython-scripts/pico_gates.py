# MicroPython script for the emulated Pico (desktop/bench/pico_gates.py copies it to the board's
# disk with the modules as .mpy and imports it): device/gates.py's Gates.sample per call, in
# emulated us (x 125: cycles), on a slow spiral over the sphere at the config's defaults (window
# 2, 100 samples a second): once without a provisional calibration (the rate gate, the coverage
# cell, add() and the batches of what is taken) and once with one (the disturbance gate's exact
# |h_c| too, in C where fitsums.mpy loads), each from a collection; Gates.sample itself in C where
# gatesc.mpy loads (device/native/gatesc.c). Prints one JSON line.
import gc
import json
import math
import time
from array import array

N = 800


def spiral(n, window=2, r=2000000.0):
    """Sums of a turn from pole to pole at ~3 degrees a sample around, 2e6 codes off a centre."""
    pts = array("i", [0] * (3 * n))
    for k in range(n):
        c = 1.0 - 2.0 * k / n
        s = math.sqrt(max(0.0, 1.0 - c * c))
        p = 0.05 * k
        pts[3 * k] = int(window * (1.004 * r * s * math.cos(p) + 30000))
        pts[3 * k + 1] = int(window * (0.997 * r * s * math.sin(p) - 20000))
        pts[3 * k + 2] = int(window * (r * c + 10000))
    return pts


def run(pts, cal):
    import config
    from gates import Gates
    from shared.coverage import Coverage
    from shared.fit import EllipsoidFit
    cfg = config.defaults()
    fit = EllipsoidFit()
    g = Gates(cfg, fit, Coverage(cfg["cells"], cfg["cell_cap"]), 2, 10.0, [0, 0, 0])
    if cal is not None:
        g.use_provisional(cal, cfg["outlier_nt"])
    s = g.sample
    gc.collect()
    t0 = time.ticks_us()
    for k in range(0, 3 * N, 3):
        s(pts[k], pts[k + 1], pts[k + 2])
    us = time.ticks_diff(time.ticks_us(), t0) / N
    return us, fit, g


pts = spiral(N)
first, fit, _ = run(pts, None)
cal = fit.solve(scale=[0.01, 0.01, 0.01], max_iter=1)
provisional, fit2, g = run(pts, cal)
print(json.dumps({"first": first, "provisional": provisional, "taken": fit.n, "taken_provisional": fit2.n,
                  "magnitude": "python" if g._exact is None else "native", "gates": getattr(g, "path", "python")}))
