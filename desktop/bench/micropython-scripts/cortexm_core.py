# MicroPython script for the bare-metal Cortex-M3 board (desktop/bench/cortexm.py imports it
# there from the board's ROM filesystem and calls main()): instruction counts of the
# calibration core. Under qemu's -icount shift=0 one instruction is one nanosecond of the
# board's clock, so a ticks_us difference x 1000 counts instructions.
# The data: a distorted sphere of 24-bit-code-sized integers (|B| = 5e6 codes, as
# micropython-scripts/core_cost.py), generated on the board before anything is counted.
import array
import gc
import json
import math
import time


def instructions(t0, t1, n=1):
    return time.ticks_diff(t1, t0) * 1000 // n


def sphere(n):
    seed = 1
    pts = array.array("i", [0] * (3 * n))
    for k in range(n):
        seed = (seed * 1103515245 + 12345) & 0x7FFFFFFF
        c = 2 * (seed / 2147483648.0) - 1
        seed = (seed * 1103515245 + 12345) & 0x7FFFFFFF
        p = 2 * math.pi * (seed / 2147483648.0)
        s = math.sqrt(1 - c * c)
        x, y, z = 5e6 * s * math.cos(p), 5e6 * s * math.sin(p), 5e6 * c
        pts[3 * k] = int(1.004 * x + 0.01 * y + 30000)
        pts[3 * k + 1] = int(0.997 * y + 20000)
        pts[3 * k + 2] = int(1.001 * z - 0.015 * x - 10000)
    return pts


def main(n=1300, quiet=8):
    try:
        import linalgc   # noqa: F401 - the solver's float kernels, as the firmware imports them at boot,
        from shared import linalg_native     # and installs them at a session's start (a revision without: none)
        linalg_native.install()
    except (ImportError, ValueError):
        pass
    from shared.fit import EllipsoidFit
    pts = sphere(n)
    out = {"n": n, "heap_free": gc.mem_free()}
    fit = EllipsoidFit()
    for k in range(0, 3 * 16, 3):         # warm: the slot width is set by the first samples
        fit.add(pts[k], pts[k + 1], pts[k + 2])
    # add() without garbage collection: a few calls with the collector off, and the bytes
    # they leave behind
    gc.collect()
    gc.disable()
    free0 = gc.mem_free()
    t0 = time.ticks_us()
    for k in range(3 * 16, 3 * (16 + quiet), 3):
        fit.add(pts[k], pts[k + 1], pts[k + 2])
    t1 = time.ticks_us()
    free1 = gc.mem_free()
    gc.enable()
    out["add_no_gc"] = instructions(t0, t1, quiet)
    out["add_bytes"] = (free0 - free1) // quiet
    # add() as it runs: every call, the collections its garbage causes included
    fit = EllipsoidFit()
    gc.collect()
    t0 = time.ticks_us()
    for k in range(0, 3 * n, 3):
        fit.add(pts[k], pts[k + 1], pts[k + 2])
    t1 = time.ticks_us()
    out["add"] = instructions(t0, t1, n)
    pts = None
    gc.collect()
    out["heap_free_before_solve"] = gc.mem_free()
    t0 = time.ticks_us()
    cal = fit.solve(scale=0.01)
    t1 = time.ticks_us()
    out["solve"] = instructions(t0, t1)
    out["iterations"] = cal.diagnostics["iterations"]
    # a provisional solve of the same sums (a device's, every solve_every_s while calibrating)
    gc.collect()
    t0 = time.ticks_us()
    fit.solve(scale=0.01, max_iter=1)
    t1 = time.ticks_us()
    out["solve_provisional"] = instructions(t0, t1)
    # a quick re-calibration on the same sums, the previous calibration's offsets ~900 codes
    # off (its gain models and the nine-parameter shape test included)
    from shared.calibration import Calibration
    prior = Calibration(cal.matrix, [cal.offset[0] + 700.0, cal.offset[1] - 500.0, cal.offset[2] + 300.0],
                        cal.field, {"predicted_error": cal.diagnostics["predicted_error"]})
    gc.collect()
    t0 = time.ticks_us()
    quick = fit.solve(scale=0.01, prior=prior)
    t1 = time.ticks_us()
    out["solve_quick"] = instructions(t0, t1)
    out["quick_gains"] = quick.diagnostics.get("gains")   # a revision before quick solves: a weak prior
    # temperature compensation: the calibration at a new die temperature (once per 0.05 C)
    if hasattr(Calibration, "at_temperature"):   # not in a revision before issue 11
        tc = Calibration(cal.matrix, cal.offset, cal.field, None, {"temperature_c": 20.0},
                         {"t0_c": 20.0, "offset_per_c": [1.5, -2.0, 0.7], "gain_per_c": [2e-5, -1e-5, 3e-5],
                          "range_c": [10.0, 30.0], "sources": 2, "method": "calibrations"})
        t0 = time.ticks_us()
        tc.at_temperature(21.5)
        t1 = time.ticks_us()
        out["at_temperature"] = instructions(t0, t1)
    print(json.dumps(out))
