"""The honest predicted error: one function for the board and the laptop.

    from shared.honest import batch_length, correlation_time, delag_share, systematic_floor, honest_error
    b = batch_length(n)                         # samples per batch for n samples in time order
    share = delag_share(rms, white, k)          # what of rms^2 is not a de-lag term's noise
    tau = correlation_time(means, counts, rms * share ** 0.5)  # from the residuals' batch means, nT
    pe = honest_error(white_pred, prior_error, tau * share, floor)

The core's predicted full-sphere error (shared.predicted) assumes independent
residuals. A sensor that lags the turn, a field that wanders or iron that moves
with the sensor leaves residuals that follow each other in time; then the N
samples weigh as N / tau independent ones, tau = 1 + 2 sum_k rho(k) the
integrated correlation time, and the error grows by sqrt(tau).

Why batch means (the method of batch means, e.g. Flegal & Jones, Ann. Stat. 38,
2010): the board cannot keep a session's residuals in time order (30,000 samples
x 3 codes x 4 B = 360 KB) to estimate tau from their autocorrelation, but the
mean residual of a batch of consecutive samples under ANY final calibration
follows from the batch's low-order power sums: |h_c|^2 = (h - b)^T M^T M (h - b)
is a quadratic in h, and |h_c| - F = (|h_c|^2 - F^2) / 2F to 1e-5 of a residual.
So the board keeps 9 sums per batch, the laptop computes the same batch means
from the residuals, and both call correlation_time on them:

    tau = sum_k n_k (m_k - m)^2 / ((K - 1) var),   var = rms^2 - m^2,

m_k the mean residual of batch k (n_k samples), m their weighted mean. White
residuals give tau ~ chi^2_(K-1) / (K - 1): 1 to within sqrt(2 / (K - 1)); only a
tau beyond its 99.4 % point counts (below, 1), so that over the two or three
batch lengths tried white residuals are widened about once in sixty. Batches longer than
the correlation are what it needs: their length doubles as a session grows, so
that BATCHES..2 BATCHES - 1 of them cover it (batch_length), 1,024 samples for a
300 s session at 100 samples/s, and the estimate is the largest over those
batches and their merges two, four... at a time while MIN_BATCHES remain (an odd
last batch left out of a merge). A correlation longer than a tenth of the longest
batch reads low by about that fraction: AR(1) series of tau 99 in 1,000 samples
read 43-62 (median), of tau 399 in 30,000, 360; the Mag648 turned at 0.1 rev/s
with its lag not undone, 4.1 nT predicted against 4.3 nT real
(tests/test_device_slow_sensor.py).

A de-lagged sample carries the derivative's noise k (8 (n_+1 - n_-1) - (n_+2 - n_-2)),
k = tau f_s / 12 (shared/delag.py), which telescopes along a run of samples: it is in the
rms the core counts as independent but hardly in a fitted parameter (the fit's sums weigh
each difference by the change of the sample's gradient over a few samples). Its variance is
known from the sample's own noise s^2: 130 k^2 s^2 (the de-lag's taps k, -8k, 1, 8k, -k),
9.1 s^2 for the Mag648 at 100 samples/s, 3 times the rms the sample's noise leaves; and the
successive differences of de-lagged residuals (the von Neumann white noise w) read
w^2 = s^2 (1 + 146 k^2) (the taps' differences). The laptop's derivative (desktop/methods/lag.py)
is the same difference over taps m samples apart, k = tau f_s / (12 m): for m >= 2 the taps'
differences do not overlap, w^2 = s^2 (1 + 130 k^2). delag_share takes 130 k^2 s^2 off rms^2 (what is left: the noise, and any error that does not telescope), and the batch
means are judged against that: the core's figure times sqrt(share tau). Judged against the
whole rms, the Mag648's read tau 0.09-0.24 where the share is 0.10, and only a bound of it
(below) narrowed the figure: 1.5-3.0 times the real full-sphere error.

Residuals whose sum cancels for another reason read tau < 1, and then the error is narrowed:
only by the shortest batches' tau, under white residuals' 0.6 % point, and only to its
upper 99.4 % bound (tau / that point: 0.12 in 18 batches gives 0.35; their ends, where the
differences do not cancel, make short batches read high too), and no lower than the longer
batches read, so that the narrowed figure errs on the side of too large. White residuals
are narrowed about once in a hundred (9 of 1,000 sets of 2,000 samples, to 0.80 at least).

A systematic floor (systematic_floor, desktop/methods/residuals.py explains it):
where the scale is pinned (a known field, a quick re-calibration), a slowly
varying one-signed error hides its mean in the scale; its size is what the rms
holds beyond twice the sample-to-sample noise.
"""

import math

BATCHES = 16          # at least this many batches once a session has FIRST * BATCHES samples
FIRST = 32            # the shortest batch, samples
MIN_BATCHES = 8       # fewer batch means than this tell too little (chi^2 of 7: +-53 %)
Z_WHITE = 2.5         # white residuals' estimate beyond this many of its standard errors counts
FLOOR_RATIO = 2.0     # rms above this multiple of the white noise leaves a systematic floor


def batch_length(n):
    """Samples per batch for n samples: FIRST doubled until n < 2 BATCHES of them."""
    b = FIRST
    while n >= 2 * BATCHES * b:
        b *= 2
    return b


def _batch_time(means, counts, rms):
    """tau as one set of batch means reads it (not yet judged against chance), and the batches used."""
    total = 0
    mean = 0.0
    k = 0
    for m, c in zip(means, counts):
        if c:
            total += c
            mean += c * m
            k += 1
    if k < MIN_BATCHES:
        return 1.0, k
    mean /= total
    var = rms * rms - mean * mean
    if not var > 0.0:
        return 1.0, k
    spread = 0.0
    for m, c in zip(means, counts):
        if c:
            spread += c * (m - mean) * (m - mean)
    return spread / ((k - 1) * var), k


def _chance_point(dof, z):
    """chi^2_dof / dof at z standard normal deviates (Wilson-Hilferty): z = +2.5 the 99.4 % point
    white residuals' estimate exceeds once in 160 (2.37 for 12 batches, 1.76 for 31), z = -2.5
    the 0.6 % point it falls under as often (0.24 for 12 batches, 0.47 for 31)."""
    a = 2.0 / (9.0 * dof)
    return max(0.0, 1.0 - a + z * math.sqrt(a)) ** 3


def correlation_time(means, counts, rms):
    """The residuals' integrated correlation time (samples) from their batch means (nT) and
    counts and their rms (nT). Over the batches and their merges into batches twice, four
    times... as long while MIN_BATCHES remain (a batch shorter than a correlation reads it
    low): the largest estimate beyond white residuals' 99.4 % point. With none beyond it, the
    shortest batches' upper 99.4 % bound when that is under 1 (residuals whose sums cancel,
    as a de-lag term's differences do; their ends make short batches read high), but no less
    than what the longer ones read; else 1.0."""
    best = 1.0
    first = None            # (tau, batches) of the shortest batches
    longer = 0.0            # the largest estimate of the longer ones
    while True:
        tau, k = _batch_time(means, counts, rms)
        if k < MIN_BATCHES:
            break
        if tau > _chance_point(k - 1, Z_WHITE):
            best = max(best, tau)
        if first is None:
            first = (tau, k)
        else:
            longer = max(longer, tau)
        merged_m = []
        merged_c = []
        for i in range(0, len(means) - 1, 2):
            c = counts[i] + counts[i + 1]
            merged_m.append((means[i] * counts[i] + means[i + 1] * counts[i + 1]) / c if c else 0.0)
            merged_c.append(c)
        means, counts = merged_m, merged_c
    if best > 1.0 or first is None:
        return best
    low = _chance_point(first[1] - 1, -Z_WHITE)
    return min(1.0, max(first[0] / low, longer)) if low > 0.0 else 1.0


def delag_share(rms, white, k, spacing=1):
    """The share of rms^2 (the residuals' mean square, nT^2) that is not a de-lag term's
    telescoping noise (module docstring), for samples de-lagged by the five-point difference
    over taps spacing samples apart (the board's: 1), k = tau f_s / (12 spacing); white: the
    residuals' von Neumann white noise (nT; None: unknown, 1.0). The noise s^2 = white^2 /
    (1 + 146 k^2) (1 + 130 k^2 where the taps' differences do not overlap); what is left is
    rms^2 - 130 k^2 s^2, no less than s^2."""
    if not k or white is None or not rms > 0.0:
        return 1.0
    k2 = k * k
    noise = white * white / (1.0 + (146.0 if spacing == 1 else 130.0) * k2)
    return min(1.0, max(rms * rms - 130.0 * k2 * noise, noise) / (rms * rms))


def systematic_floor(rms, white):
    """sqrt(max(0, rms^2 - (2 white)^2)), nT: the error a pinned scale cannot average away."""
    return math.sqrt(max(0.0, rms * rms - (FLOOR_RATIO * white) ** 2))


def honest_error(white_pred, prior_error, tau, floor):
    """The predicted full-sphere error (nT): the core's white-noise one (white_pred, which
    holds a previous calibration's own error prior_error in quadrature: that one does not
    come from these samples and is not scaled) scaled by sqrt(tau) (narrowed where tau < 1),
    and at least floor (0 unless the scale was pinned)."""
    prev = prior_error or 0.0
    data_sq = max(0.0, white_pred * white_pred - prev * prev)
    return max(math.sqrt(data_sq * tau + prev * prev), floor)
