"""Whether |B| reads low as the sensor turns faster: the one turn-rate check of a calibrated recording.

    effect = rate_effect(corrected, field, t)     # RateEffect(slope, se, w90, correlation) or None
    grid = error_by_direction(corrected, field)   # mean |h_c| - field per equal-area bin, nT

A sensor that lags the turn (first order, time constant tau) reads |h| short by B (tau w)^2 / 2,
and a block mean of turning vectors by B (w T)^2 / 24 (docs/experiments/lag.md): the residual
|h_c| - field falls as the square of the rate w. The residual of an orientation (a sensor not
linear, iron turning with it) does not follow the rate, but a hand turns faster through some
orientations than others: each residual is taken less the mean of its direction's bin first, so
that only the rate is left to explain it. `fluxcal fit` and `report` ask the question of their
refusal (desktop/methods/refusal.py: the correlation, which says lag or not) and of their
verdict (desktop/views/verdict.py: the slope in nT, which says by how much) from this one fit.
"""

import collections
import math

import numpy as np

ERR_COLS, ERR_ROWS = 36, 12        # bins of the error map: 432 equal areas, ~95 square degrees each
MIN_SAMPLES = 20                   # fewer: no rate effect is told

# slope: |h_c| - field at the rate w90 less at rest, nT (a + slope (w / w90)^2 fitted); se: its
# standard error; w90: the 90th-percentile rate (degrees per unit of t); correlation: of the
# residuals with w^2, -1..1 (negative: |B| falls as the turn speeds up)
RateEffect = collections.namedtuple("RateEffect", "slope se w90 correlation")


def lon_z(d):
    """(longitude about Z in degrees, z of the unit vector) of (..., 3) directions: the equal-area map's coordinates."""
    d = np.asarray(d, dtype=float)
    n = np.linalg.norm(d, axis=-1)
    return np.degrees(np.arctan2(d[..., 1], d[..., 0])), d[..., 2] / n


def error_bins(corrected):
    """The equal-area bin (row * ERR_COLS + col) of each (N, 3) sample's direction."""
    lon, z = lon_z(corrected)
    col = np.clip(((lon + 180.0) / 360.0 * ERR_COLS).astype(int), 0, ERR_COLS - 1)
    row = np.clip(((1.0 - z) / 2.0 * ERR_ROWS).astype(int), 0, ERR_ROWS - 1)
    return row * ERR_COLS + col


def error_by_direction(corrected, field):
    """(mean |h_c| - field per equal-area bin, NaN where no sample fell; (rows, cols) array, nT)."""
    flat = error_bins(corrected)
    resid = np.linalg.norm(corrected, axis=1) - field
    total = np.bincount(flat, weights=resid, minlength=ERR_ROWS * ERR_COLS)
    n = np.bincount(flat, minlength=ERR_ROWS * ERR_COLS)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 0, total / np.maximum(n, 1), np.nan)
    return mean.reshape(ERR_ROWS, ERR_COLS)


def rotation_rate(corrected, t):
    """The turn rate at each sample but the first and the last, (N - 2,): the angle between the
    directions before and after it over the time between them, degrees per unit of t (a central
    difference: the rate at the sample, which its lag answers to, not the step before it)."""
    u = corrected / np.linalg.norm(corrected, axis=1)[:, None]
    dot = np.clip(np.sum(u[2:] * u[:-2], axis=1), -1.0, 1.0)
    t = np.asarray(t, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.degrees(np.arccos(dot)) / (t[2:] - t[:-2])
    return rate


def rate_residuals(corrected, field, t):
    """(rate, residual) at each sample but the first and the last, the residual less its direction's
    mean (the error map's bin): the orientations a hand turns fast through must not pass for a rate effect."""
    rate = rotation_rate(corrected, t)
    resid = np.linalg.norm(corrected, axis=1) - field
    mean = np.nan_to_num(error_by_direction(corrected, field).ravel())
    r = (resid - mean[error_bins(corrected)])[1:-1]
    ok = np.isfinite(rate)
    return rate[ok], r[ok]


def rate_effect(corrected, field, t=None):
    """How |B| follows the square of the turn rate: fits |h_c| - field = a + slope (w / w90)^2 on the
    samples (their direction's mean removed); RateEffect, or None with fewer than MIN_SAMPLES samples
    or no motion. t: the samples' times (None: their numbers, the rate then per sample)."""
    corrected = np.asarray(corrected, dtype=float)
    if t is None:
        t = np.arange(len(corrected), dtype=float)
    if len(corrected) < MIN_SAMPLES + 2 or not (np.linalg.norm(corrected, axis=1) > 0).all():
        return None
    rate, r = rate_residuals(corrected, field, t)
    if len(rate) < MIN_SAMPLES or not np.ptp(rate) > 0:
        return None
    w90 = float(np.percentile(rate, 90))
    x = (rate / w90) ** 2 if w90 > 0 else rate ** 2
    a = np.vstack([np.ones_like(x), x]).T
    coef, *_ = np.linalg.lstsq(a, r, rcond=None)
    resid_fit = r - a @ coef
    cov = np.linalg.pinv(a.T @ a) * (resid_fit @ resid_fit) / max(1, len(r) - 2)
    corr = float(np.corrcoef(r, x)[0, 1]) if r.std() > 0 else 0.0
    return RateEffect(float(coef[1]), float(math.sqrt(max(0.0, cov[1, 1]))), w90, corr)
