# MicroPython script for the emulated Pico (desktop/bench/pico_tau.py runs it): what the firmware's tau
# estimate costs (shared/tausums.py): TauSums.add per accepted sample (four EllipsoidFit.add), the
# search over tau (one-step solves, as device/lagfit.py), the final solve. The data: a distorted sphere
# (cortexm_core.sphere, |B| 5e6 codes) whose samples lag by t = -1.6
# steps along a turn whose rate varies, so that the search has a least to find. Prints one JSON line.
import array
import gc
import json
import time


def us(t0, t1, n=1):
    return time.ticks_diff(t1, t0) * 1000 // n


def main(n=1300):
    from cortexm_core import sphere
    from shared.fit import EllipsoidFit
    from shared.tausums import TauSums, lagrange_sums, minimise
    v = sphere(n)
    fit = EllipsoidFit()
    pts = array.array("i", [0] * (6 * n))
    for k in range(n):
        x, y = v[3 * k], v[3 * k + 1]
        # a step term along the turn, ~0.3 % of |B| times a rate that varies (a hand's), and the
        # samples lagging by t0 steps of it: x + t0 e is the sphere
        w = 0.5 + (k % 7) / 7.0
        ex, ey = int(-y * 0.003 * w), int(x * 0.003 * w)
        t0 = -1.6
        pts[6 * k] = x - int(t0 * ex) + (k % 5) - 2
        pts[6 * k + 1] = y - int(t0 * ey) + (k % 3) - 1
        pts[6 * k + 2] = v[3 * k + 2] + (k % 4) - 2
        pts[6 * k + 3] = ex
        pts[6 * k + 4] = ey
        fit.add(pts[6 * k], pts[6 * k + 1], pts[6 * k + 2])   # the fit's own (cortexm_core times add())
    v = None
    out = {"n": n}
    ts = TauSums()
    gc.collect()
    t1 = time.ticks_us()
    for k in range(0, 6 * n, 6):
        ts.add(pts[k], pts[k + 1], pts[k + 2], pts[k + 3], pts[k + 4], pts[k + 5])
    t2 = time.ticks_us()
    out["tausums_add_ns"] = us(t1, t2, n)
    pts = None
    gc.collect()
    centre = fit.sums()
    nodes = ts.sums()
    calls = [0]

    def rms_at(p, q):
        calls[0] += 1
        return EllipsoidFit.from_sums(lagrange_sums(centre, nodes, p, q)).solve(
            field=None, scale=[0.01 / q] * 3, max_iter=1).diagnostics.get("rms")

    t0 = time.ticks_us()
    t, sigma, rms = minimise(rms_at, n, -5, 5, 64)
    t1 = time.ticks_us()
    out["search_ns"] = us(t0, t1)
    out["solves"] = calls[0]
    out["t"] = t
    p = round(t * 64)
    t0 = time.ticks_us()
    EllipsoidFit.from_sums(lagrange_sums(centre, nodes, p, 64)).solve(field=None, scale=[0.01 / 64] * 3)
    t1 = time.ticks_us()
    out["final_solve_ns"] = us(t0, t1)
    t0 = time.ticks_us()
    fit.solve(field=None, scale=[0.01] * 3)
    t1 = time.ticks_us()
    out["configured_solve_ns"] = us(t0, t1)
    print(json.dumps(out))
