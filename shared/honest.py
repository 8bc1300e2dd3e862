"""The honest predicted error: one function for the board and the laptop.

    from shared.honest import batch_length, correlation_time, systematic_floor, honest_error
    b = batch_length(n)                         # samples per batch for n samples in time order
    tau = correlation_time(means, counts, rms)  # from the residuals' batch means, nT
    pe = honest_error(white_pred, prior_error, tau, floor)

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
    """tau from one set of batch means, or 1.0 when not beyond chance; and the batches used."""
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
    tau = spread / ((k - 1) * var)
    return (tau if tau > _white_bound(k - 1) else 1.0), k


def _white_bound(dof):
    """The 99.4 % point of chi^2_dof / dof (Wilson-Hilferty, z = 2.5): what white residuals'
    estimate exceeds once in 160 at each batch length tried (2.37 for 12 batches, 1.76 for 31)."""
    a = 2.0 / (9.0 * dof)
    return (1.0 - a + Z_WHITE * math.sqrt(a)) ** 3


def correlation_time(means, counts, rms):
    """The residuals' integrated correlation time (samples) from their batch means (nT) and
    counts and their rms (nT): the largest over the batches and their merges into batches
    twice, four times... as long while MIN_BATCHES remain (a batch shorter than the
    correlation reads it low); at each length 1.0 where it is not beyond chance (_white_bound)."""
    best = 1.0
    while True:
        tau, k = _batch_time(means, counts, rms)
        if k < MIN_BATCHES:
            return best
        best = max(best, tau)
        merged_m = []
        merged_c = []
        for i in range(0, len(means) - 1, 2):
            c = counts[i] + counts[i + 1]
            merged_m.append((means[i] * counts[i] + means[i + 1] * counts[i + 1]) / c if c else 0.0)
            merged_c.append(c)
        means, counts = merged_m, merged_c


def systematic_floor(rms, white):
    """sqrt(max(0, rms^2 - (2 white)^2)), nT: the error a pinned scale cannot average away."""
    return math.sqrt(max(0.0, rms * rms - (FLOOR_RATIO * white) ** 2))


def honest_error(white_pred, prior_error, tau, floor):
    """The predicted full-sphere error (nT): the core's white-noise one (white_pred, which
    holds a previous calibration's own error prior_error in quadrature: that one does not
    come from these samples and is not widened) widened by sqrt(tau), and at least floor
    (0 unless the scale was pinned)."""
    prev = prior_error or 0.0
    data_sq = max(0.0, white_pred * white_pred - prev * prev)
    return max(math.sqrt(data_sq * max(1.0, tau) + prev * prev), floor)
