"""An honest predicted error from the residuals in time order.

    from desktop.methods.residuals import honest_error
    h = honest_error(cal, raw, pinned=field is not None or prior is not None)
    h["predicted_error"], h["tau_int"], h["floor"]     # nT, samples, nT

The core's predicted full-sphere error (shared.predicted) is the posterior
spread of a fit whose residuals are white noise: Cov(p) = (RSS/N) H^-1. Two
things break that when the sensor moves faster than it can follow (a 5 Hz
fluxgate turned by hand, an ADC window that smears a turning vector): the
residuals r_i = |h_c,i| - F are correlated in time, and part of the error is
systematic. Both are read off the residuals themselves.

1. Correlation: the effective sample size
-----------------------------------------
The parameter error is a weighted sum of the residuals, dp = H^-1 sum_i g_i r_i / N.
With autocorrelation rho(k) and weights that vary slowly compared with it

    Var(sum_i g_i r_i) = sigma^2 sum_i g_i^2 tau_int,   tau_int = 1 + 2 sum_{k>=1} rho(k),

so the N samples weigh as N / tau_int independent ones and the predicted
error grows by sqrt(tau_int). tau_int is estimated from the residuals' batch
means by shared.honest, the function the firmware runs on its session's batch
sums (device/residuals.py), so that one set of samples gets one figure on
the board and here: tau_int = sum_k n_k (m_k - m)^2 / ((K - 1) var) over K
batches of consecutive samples, 1 unless beyond two standard errors of white
noise's. The residual per sample is (|h_c|^2 - F^2) / 2F, which is what the
board's batch sums give (it differs from |h_c| - F by r^2 / 2F, 1e-5 nT).
A previous calibration's own error, which a quick re-calibration adds in
quadrature (diagnostics["prior_error"], shared.quick), does not come from these
samples and is not inflated. integrated_time (Sokal's automatic window, A.
Sokal, "Monte Carlo methods in statistical mechanics", 1996) stays for the
lag estimate's batch length (desktop.methods.lag), which needs no board.

2. A systematic floor
---------------------
Write r_i = s_i + w_i, a slowly varying systematic part s (variance sigma_s^2)
and white noise w (sigma_w^2). The mean square successive difference (von
Neumann) sees only the white part when s varies slowly:
mean((r_{i+1} - r_i)^2) / 2 = sigma_w^2 + sigma_s^2 (1 - rho_s(1)) ~ sigma_w^2, so

    sigma_s^2 = rms^2 - sigma_w^2.

What the residuals cannot show is the systematic part's *mean*: the fit
drives the residual mean to zero through its scale (the gain of M when the
field is known, the fitted radius when it is not). The errors of a turning
sensor are one-signed: a first-order low pass y' = (h - y) / tau lags h by
y ~ h - tau h' + tau^2 h'', and since |h| = B is constant (h.h' = 0,
h.h'' = -|h'|^2)

    |y|^2 = B^2 - 2 tau h.h' + tau^2 (|h'|^2 + 2 h.h'') = B^2 - tau^2 |h'|^2,
    |y| - B ~ -B (tau w)^2 / 2,

w the rate at which the field turns in the sensor frame (an averaging
window T gives -B (w T)^2 / 24 alike). Both are proportional to w^2 = w_1^2 + w_2^2,
the two components of the turning rate across the field. For a hand's
turning (zero-mean components of equal spread) w^2 is exponentially
distributed, whose mean equals its standard deviation: the hidden mean is
about sigma_s (for one or three Gaussian components 0.71 or 1.22 sigma_s).
When the scale is pinned, by a known field or by the previous calibration's
field in a quick re-calibration, that mean is a common error of |h_c| in every
orientation, so the full-sphere error is at least sigma_s, whatever N. When
the field is fitted, the core fixes det M = 1 and the mean moves the fitted
field (cal.field, low by about sigma_s) instead of |h_c|: no floor then.

Only a strong correlation counts. Zero-mean noise correlated over a few
samples (the ADS1292's sinc3 windows overlap three conversions) also lifts
the rms over sigma_w, rms^2 = sigma_w^2 / (1 - rho(1)), without a mean to
hide. The floor therefore takes only the excess over 2 sigma_w (rho(1) > 3/4,
the residuals "greatly exceed" white noise),

    floor = sqrt(max(0, rms^2 - 4 sigma_w^2)),

which is continuous at the threshold; every simulated lag and smearing case
has rho(1) > 0.93 (docs/simulator.md, "Sensor lag").

The honest predicted error is max(sqrt(tau_int) x the white one, floor).
The residuals must be in time order (a capture, a logged CSV); shuffled
samples look white (tau_int ~ 1) and leave the core's value unchanged.
"""

import math

import numpy as np

from desktop.methods import correct_array
from shared import honest

SOKAL_C = 5.0


def autocorrelation(x):
    """rho(k), k = 0..N-1, of a series (mean removed; biased estimator, FFT)."""
    x = np.asarray(x, dtype=float)
    x = x - x.mean()
    n = len(x)
    size = 1 << int(2 * n - 1).bit_length()
    f = np.fft.rfft(x, size)
    acov = np.fft.irfft(f * np.conj(f), size)[:n]
    if not acov[0] > 0:
        return np.r_[1.0, np.zeros(n - 1)]
    return acov / acov[0]


def integrated_time(x, c=SOKAL_C):
    """Integrated autocorrelation time (samples) with Sokal's window; returns (tau, window M)."""
    rho = autocorrelation(x)
    taus = 2.0 * np.cumsum(rho) - 1.0          # tau(M) = 1 + 2 sum_{k=1..M} rho(k)
    m = np.arange(len(rho))
    ok = np.flatnonzero(m >= c * taus)
    k = int(ok[0]) if len(ok) else len(rho) - 1
    return float(taus[k]), k


def white_rms(r):
    """White-noise part of a series: sqrt(mean square successive difference / 2)."""
    d = np.diff(np.asarray(r, dtype=float))
    return float(np.sqrt(np.mean(d * d) / 2.0)) if len(d) else 0.0


def batch_means(r):
    """(means, counts) of r over consecutive batches of shared.honest.batch_length(len(r))."""
    r = np.asarray(r, dtype=float)
    b = honest.batch_length(len(r))
    edges = np.arange(0, len(r), b)
    counts = np.diff(np.r_[edges, len(r)])
    return (np.add.reduceat(r, edges) / counts).tolist(), counts.tolist()


def residual_stats(r, delag=None):
    """dict: rms, white (sigma_w), tau_int (shared.honest.correlation_time), batch (its
    length), floor (shared.honest.systematic_floor), delag_share (shared.honest.delag_share:
    1 unless delag, (k, spacing) of the five-point difference the samples were de-lagged by,
    desktop.methods.lag.delag_taps)."""
    r = np.asarray(r, dtype=float)
    rms = float(np.sqrt(np.mean(r * r)))
    white = white_rms(r)
    means, counts = batch_means(r)
    # the de-lag term's noise telescopes: the batch means are judged against the rest of the
    # rms, the board's way (device/session.py _widen)
    share = honest.delag_share(rms, white, *delag) if delag else 1.0
    tau = honest.correlation_time(means, counts, rms * math.sqrt(share))
    return {"rms": rms, "white": white, "tau_int": tau, "batch": honest.batch_length(len(r)),
            "floor": honest.systematic_floor(rms, white), "delag_share": share}


def honest_error(cal, h, pinned, delag=None):
    """The honest predicted full-sphere error of a calibration fitted to h (N, 3) nT in time order.

    pinned: the calibration's scale was fixed from outside (a known field or a
    previous calibration), so a hidden systematic mean is an error of |h_c|.
    delag: (k, spacing) where h was de-lagged (residual_stats), None where not.
    Returns residual_stats(...) plus predicted_error (honest), predicted_error_white
    (the core's), applied_floor (0 unless pinned); predicted_error is None when
    the calibration carries no predicted error (the numpy reference methods).
    """
    hc = correct_array(cal, h)
    r = (np.einsum("ij,ij->i", hc, hc) - cal.field * cal.field) / (2.0 * cal.field)
    out = residual_stats(r, delag)
    d = cal.diagnostics
    # the core's, also where the calibration was widened already (a board's, a written one)
    white_pred = d.get("predicted_error_white", d.get("predicted_error"))
    out["predicted_error_white"] = white_pred
    out["applied_floor"] = out["floor"] if pinned else 0.0
    if white_pred is None:
        out["predicted_error"] = None
        return out
    out["predicted_error"] = honest.honest_error(float(white_pred), float(cal.diagnostics.get("prior_error") or 0.0),
                                                 out["tau_int"] * out["delag_share"], out["applied_floor"])
    return out
