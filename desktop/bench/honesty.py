"""Is the predicted error honest? `python -m desktop.bench.honesty` prints the README tables.

1. Predicted vs real full-sphere error across a grid of coverage (full sphere
   down to a 1 % cap), noise and prior (none: a full fit; previous: a quick
   re-calibration after a drift). The predicted error is a standard deviation,
   and one sensor's real error is one draw (on a small cap nearly all of it
   along one direction: |N(0, 1)|-like, anywhere in 0.1-2.5x), so the ratio is
   taken over sensors: RMS(real) / RMS(predicted). With S sensors its own
   spread is about 1/sqrt(2 S) (16 % for 20).
2. Quick re-calibration after offsets drift 5-20 nT and the common gain 100
   ppm (σ = 1 nT, 3000 samples): full-sphere error after a 10 % and a 26 %
   cap, mean / worst of 5 sensors, beside the stale calibration, the cap alone,
   the nine-parameter fit weakly tied to the previous one (the quick fit's
   predecessor) and the noise limit, the quick fit with the true shape.
"""

import argparse
import time

import numpy as np

from desktop.methods import LSB_NT, accumulate, fit_array, magnitudes
from desktop.sim.field import EARTH_NT as FIELD
from desktop.sim.points import directions
from desktop.sim.sensor import Sensor
from shared.calibration import Calibration
from shared.fit import FitError

COVERAGES = (1.0, 0.6, 0.26, 0.1, 0.03, 0.01)


def rms(x):
    return float(np.sqrt(np.nanmean(np.square(x))))


def fit(h, prior=None, quick=True):
    """The streaming fit of raw nT h with B known; no refusal (the predicted error is what is judged)."""
    if prior is not None:
        prior = prior.scaled_input(1.0 / LSB_NT)
    return accumulate(h, LSB_NT).solve(field=FIELD, prior=prior, scale=LSB_NT, quick=quick,
                                       max_error=float("inf")).scaled_input(LSB_NT)


def drifted_day(seed, noise=1.0, n=3000):
    """A sensor calibrated from a tumble, then drifted: offsets 5-20 nT, common gain 100 ppm.

    Returns (sensor after the drift, previous calibration, the true shape as a calibration, sphere points)."""
    rng = np.random.default_rng(seed)
    sensor = Sensor.random(rng, 1.0, 0.005, 1000.0, noise)
    m0, b0 = sensor.true_correction()
    old = fit_array(sensor.measure(FIELD * directions("tumble", rng, 2 * n), rng), field=FIELD)
    true_shape = Calibration(m0.tolist(), [float(b) for b in b0], FIELD, {"predicted_error": 0.0})
    sensor.offset = sensor.offset + rng.choice([-1.0, 1.0], 3) * rng.uniform(5.0, 20.0, 3)
    sensor.scale = sensor.scale * (1.0 + 1e-4)
    sphere = FIELD * directions("uniform", rng, 20000) @ sensor.distortion.T + sensor.offset
    return sensor, old, true_shape, sphere, rng


def sphere_error(cal, sphere):
    return rms(magnitudes(cal, sphere) - FIELD)


def honesty(sensors, n=3000):
    """Rows (coverage, noise, prior, RMS real, RMS predicted, failures)."""
    rows = []
    for noise in (0.1, 1.0):
        for prior in ("none", "previous"):
            for cov in COVERAGES:
                if prior == "previous" and cov == 1.0:
                    continue
                real, pred, failed = [], [], 0
                for seed in range(sensors):
                    sensor, old, _, sphere, rng = drifted_day(1000 + seed, noise, n)
                    kind = "uniform" if cov == 1.0 else "cap"
                    raw = sensor.measure(FIELD * directions(kind, rng, n, cov), rng)
                    try:
                        cal = fit(raw, old if prior == "previous" else None)
                    except FitError:
                        failed += 1
                        continue
                    real.append(sphere_error(cal, sphere))
                    pred.append(cal.diagnostics["predicted_error"])
                rows.append((cov, noise, prior, rms(real), rms(pred), failed))
    return rows


def recalibration(sensors=5, n=3000, coverages=(0.1, 0.26)):
    """{coverage: {column: [full-sphere error per sensor]}}."""
    out = {}
    for cov in coverages:
        res = {k: [] for k in ("stale", "cap alone", "weak prior", "quick", "true shape", "predicted")}
        for seed in range(sensors):
            sensor, old, true_shape, sphere, rng = drifted_day(seed, 1.0, n)
            cap = sensor.measure(FIELD * directions("cap", rng, n, cov), rng)
            res["stale"].append(sphere_error(old, sphere))
            try:
                res["cap alone"].append(sphere_error(fit(cap), sphere))
            except FitError:
                res["cap alone"].append(float("nan"))
            res["weak prior"].append(sphere_error(fit(cap, old, quick=False), sphere))
            q = fit(cap, old)
            res["quick"].append(sphere_error(q, sphere))
            res["predicted"].append(q.diagnostics["predicted_error"])
            res["true shape"].append(sphere_error(fit(cap, true_shape), sphere))
        out[cov] = res
    return out


def print_honesty(rows, sensors):
    print("### Predicted vs real full-sphere error (nT; RMS over %d sensors, 3000 samples, B known)\n" % sensors)
    print("| coverage | sigma | prior | real | predicted | real / predicted | refused |")
    print("|---|---|---|---|---|---|---|")
    for cov, noise, prior, real, pred, failed in rows:
        print("| %s | %.1f | %s | %.3f | %.3f | %.2f | %d |" % (
            "sphere" if cov == 1.0 else "cap %g %%" % (cov * 100), noise, prior, real, pred, real / pred, failed))


def print_recalibration(out, sensors):
    for cov, res in out.items():
        print("\n### Quick re-calibration: %g %% cap after offsets drift 5-20 nT and the common gain 100 ppm "
              "(sigma = 1 nT, 3000 samples; full-sphere error, nT; mean / worst of %d)\n" % (cov * 100, sensors))
        print("| stale | cap alone | cap + weak prior (9 parameters) | **quick** (predicted) | quick with the true shape |")
        print("|---|---|---|---|---|")
        cell = lambda v: "%.3f / %.3f" % (np.nanmean(v), np.nanmax(v))
        print("| %s | %s | %s | **%s** (%.3f) | %s |" % (cell(res["stale"]), cell(res["cap alone"]), cell(res["weak prior"]),
                                                        cell(res["quick"]), np.mean(res["predicted"]), cell(res["true shape"])))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sensors", type=int, default=20, help="sensors per cell of the honesty grid")
    p.add_argument("--recal-sensors", type=int, default=5)
    args = p.parse_args(argv)
    t0 = time.time()
    print_honesty(honesty(args.sensors), args.sensors)
    print_recalibration(recalibration(args.recal_sensors), args.recal_sensors)
    print("\n(%.0f s; command: python -m desktop.bench.honesty --sensors %d --recal-sensors %d)"
          % (time.time() - t0, args.sensors, args.recal_sensors))


if __name__ == "__main__":
    main()
