"""The quick re-calibration's shape test decides at chi^2's 0.1 % point (shared/quick.py), from both sides.

Under an unchanged shape the likelihood ratio N log(RSS_quick / RSS_full) is chi^2 with
k = 6 - (gains fitted) degrees of freedom; a real shape change adds a noncentrality
lam = sum r_i^2 / sigma^2, with r_i what the best quick model (previous shape, a common
gain, offsets) leaves of the noise-free readings. So:
- a pure offset/gain drift must stay below T = chi^2_k(0.999) (a false flag 0.1 % a draw);
- a shape change built so that lam puts the ratio between T and 10 T with odds better
  than 1000:1 each side must be flagged: a threshold too high (x10) or too low misses it.
The previous calibration is the sensor's exact inverse, so no fitting error of its own
adds noncentrality to the drift-only case.
"""

import copy
import math

import numpy as np

from desktop.bench.honesty import FIELD, fit
from desktop.sim.points import directions
from desktop.sim.sensor import Sensor
from shared.calibration import Calibration
from tests.chi2 import chi2_cdf, ncchi2_cdf

NOISE = 1.0      # nT per axis: the radial noise of |h_c| too, as M is the identity within 0.5 %
N = 3000
COVERAGE = 0.26
K = 5            # six shape terms less one common gain
T = 20.52        # chi^2_5's 0.1 % point, the documented level (shared/quick.py CHI2_001)
# The real change sits at the geometric middle of T and 10 T: its mean k + lam there.
LAM = math.sqrt(10.0) * T - K


def drifted(seed):
    """(sensor after a drift of offsets 12/-8/15 nT and gain 100 ppm, its exact previous calibration, rng)."""
    rng = np.random.default_rng(seed)
    s = Sensor.random(rng, 1.0, 0.005, 1000.0, NOISE)
    m0, b0 = s.true_correction()
    prev = Calibration(m0.tolist(), [float(b) for b in b0], FIELD, {"predicted_error": 0.0})
    s.offset = s.offset + np.array([12.0, -8.0, 15.0])
    s.scale = s.scale * (1.0 + 1e-4)
    return s, prev, m0, rng


def tilt(sensor, degrees):
    """Turn the sensor's Y axis towards Z's normal by `degrees`: a shape change no gain explains."""
    t = math.radians(degrees)
    axes = sensor.axes.copy()
    axes[1] = axes[1] * math.cos(t) + np.cross(axes[1], axes[2]) * math.sin(t)
    sensor.axes = axes / np.linalg.norm(axes, axis=1)[:, None]


def quick_misfit(h, m0, groups):
    """Residuals |diag(g) M0 (h - b)| - F of the best gains g (axis i's is group groups[i]'s, as
    shared/quick.py GAIN_MODELS) and offsets b on noise-free h (Gauss-Newton, from the previous ones)."""
    sel = np.array([[groups[i] == k for k in range(max(groups) + 1)] for i in range(3)], dtype=float)
    g, b = np.ones(sel.shape[1]), np.zeros(3)
    for _ in range(20):
        v = (h - b) @ m0.T
        hc = v * (sel @ g)
        r = np.linalg.norm(hc, axis=1)
        u = hc / r[:, None]
        jac = np.column_stack([(u * v) @ sel, -(u * (sel @ g)) @ m0])
        step = np.linalg.lstsq(jac, r - FIELD, rcond=None)[0]
        g, b = g - step[:len(g)], b - step[len(g):]
    return np.linalg.norm((h - b) @ m0.T * (sel @ g), axis=1) - FIELD


def noncentrality(sensor, field, m0, groups=(0, 0, 0)):
    clean = field @ sensor.distortion.T + sensor.offset
    return float(np.sum(quick_misfit(clean, m0, groups) ** 2)) / NOISE ** 2


def test_the_design_puts_the_decision_between_t_and_10t():
    # the margins the tests below rely on, from the distribution alone
    assert abs(1.0 - chi2_cdf(T, K) - 1e-3) < 1e-5          # T is the 0.1 % point
    assert ncchi2_cdf(T, K, LAM) < 1e-3                       # the real change falls below T
    assert 1.0 - ncchi2_cdf(10 * T, K, LAM) < 1e-3            # ... or above 10 T: rarer than 1 in 1000
    # five drift-only draws all below T / 10 (a threshold ten times too low passes them all): 1e-4
    assert chi2_cdf(T / 10, K) ** 5 < 1e-3


def test_a_pure_offset_and_gain_drift_is_not_flagged():
    lrs = []
    for seed in range(5):
        s, prev, _, rng = drifted(seed)
        q = fit(s.measure(FIELD * directions("cap", rng, N, COVERAGE), rng), prev)
        d = q.diagnostics
        assert d["mode"] == "quick" and d["gains"] == 1, d
        lrs.append(d["shape_lr"])
    # each is a chi^2_5 draw: below T (0.999 each); not all below T / 10 (p = 1e-4)
    assert max(lrs) < T, lrs
    assert max(lrs) > T / 10, lrs


def test_a_shape_change_near_the_threshold_is_flagged():
    # the whole sphere: there a tilt (an off-diagonal shape term) is orthogonal to the gains,
    # so no gain model the quick fit may choose absorbs it (asserted below)
    s, prev, m0, rng = drifted(7)
    field = FIELD * directions("uniform", rng, N)
    probe = 0.01                                   # degrees; lam grows as the tilt squared
    tilted = copy.deepcopy(s)
    tilt(tilted, probe)
    degrees = probe * math.sqrt(LAM / noncentrality(tilted, field, m0))
    tilt(s, degrees)
    lam = noncentrality(s, field, m0)
    assert abs(lam / LAM - 1.0) < 0.05, lam        # first order in the tilt: 5 % is its curvature
    assert noncentrality(s, field, m0, (0, 1, 2)) > 0.95 * lam   # per-axis gains explain < 5 % of it
    q = fit(s.measure(field, rng), prev)
    d = q.diagnostics
    assert d["mode"] == "reshaped", d
    # a noncentral chi^2_5(lam) draw: inside its central 99.8 % (the statistic has the scale the
    # threshold assumes); the bounds lie between T and 10 T (test above)
    assert ncchi2_cdf(d["shape_lr"], K, lam) > 1e-3 and ncchi2_cdf(d["shape_lr"], K, lam) < 1 - 1e-3, (d["shape_lr"], lam)
