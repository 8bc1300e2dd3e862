"""De-lagging a slow sensor on the laptop: its first-order response, given or estimated.

    from desktop.methods.lag import delag, estimate_response
    resp = estimate_response(h, t)                 # dict: tau_s (3,), tau_sigma_s (3,), ...
    x = delag(h, t, resp["tau_s"])                 # what the sensor would read without its lag

A first-order sensor (time constant tau = 1 / (2 pi f_c)) reading the undelayed
signal r obeys tau y' + y = r, so r = y + tau y' exactly: the derivative undoes the
lag. It is taken over +-SPAN_S (:func:`derivative`): a central difference of
neighbours would carry white noise sigma tau / (dt sqrt 2) (5 nT per sample for the
Mag648 at 1000 SPS), and that noise, squared in |B|, biases the search towards a
smaller tau (27 % at 0.1 rev/s); over +-5 ms it is about 4 times less. A plain
difference over the span reads y' low by (w T)^2 / 6, and a hand's tremor (w ~ 50
rad/s) makes that an error of |B| that follows the squared rate; the Richardson
combination of two spans leaves (w T)^4 / 30.

Estimating tau, per axis. A common tau is not enough: axes whose bandwidths differ by
a few per cent lag by different times, and a lag difference dtau between two axes reads
a turning field like a skew between the channels, an error of |B| of order B w dtau
(150 nT at 1 rev/s for 1 ms), first order in the rate; the same tau error common to all
axes moves |B| by B (w dtau)^2 / 2 only. So:

1. a common tau by a 1-D search: the residual rms of the algebraic ellipsoid fit
   (desktop.methods.algebraic, 0.04 s on 120,000 samples) on a log grid, then golden
   section between the best point's neighbours;
2. Gauss-Newton (with instruments, :func:`_solve`) on the joint model |M (h + tau o h' - b)| = F (M symmetric, b, three
   taus; F held at the algebraic fit's, M carries the scale), from that start;
3. the taus' covariance in its instrumental sandwich form, the score's covariance from
   batch sums with their neighbours' (:func:`score_covariance`).

The model check. A response of higher order leaves, after first-order de-lagging,
r = x + kappa y'' (two equal poles tau_p: r = y + 2 tau_p y' + tau_p^2 y'', kappa of the
order of tau_p^2); since h.h'' = -|h'|^2 for a turning field of constant length, |M x - b|
reads |B| + kappa |M h'|^2 / F: residuals that follow the squared turn rate. Its coefficient is fitted beside the
others; one significant (4 sigma) and worth more than RESPONSE_MODEL_NT says the
first-order model does not represent the sensor.
"""

import math

import numpy as np

from desktop.methods.residuals import integrated_time

TAU_MAX_S = 0.5                      # 0.3 Hz: slower than any fluxgate's bandwidth
GRID = np.concatenate([[0.0], np.geomspace(1e-4, TAU_MAX_S, 28)])
GAUSS_NEWTON_STEPS = 6
SIGNIFICANT = 4.0                     # sigmas for "seen": tau identified, or a model error present
RESPONSE_MODEL_NT = 0.3               # rms of |B| the unmodelled term must explain to count (nT)
# how far a configured tau (--lag-prior: a datasheet's bandwidth, a typical value) is trusted
PRIOR_SHARE = 0.5
SPAN_S = 0.005                        # half-width of the derivative's difference, s
# the model check's rate column: a span whose samples the de-lagging's do not share, so
# that its noise and the residuals' are independent
CHECK_SPAN_S = 0.02


def _difference(h, t, k):
    n = len(h)
    i = np.arange(n)
    hi, lo = np.minimum(i + k, n - 1), np.maximum(i - k, 0)
    return (h[hi] - h[lo]) / (t[hi] - t[lo])[:, None]


def span_samples(t, span_s=SPAN_S):
    """k: the samples in span_s at the times t's mean rate (at least 1)."""
    n = len(t)
    return max(1, int(round(span_s * (n - 1) / (t[-1] - t[0])))) if n > 1 and t[-1] > t[0] else 1


def derivative(h, t, span_s=SPAN_S):
    """dh/dt (N, 3) per s from differences over +-k and +-2k samples (k in span_s; the
    indices held at the ends), combined as (4 D_k - D_2k) / 3 (Richardson): D_k reads y'
    low by (w T)^2 / 6, the combination by (w T)^4 / 30 only; t (N,) s, rising."""
    h = np.asarray(h, dtype=float)
    t = np.asarray(t, dtype=float)
    k = span_samples(t, span_s)
    return (4.0 * _difference(h, t, k) - _difference(h, t, 2 * k)) / 3.0


def delag(h, t, tau):
    """h + tau o dh/dt: readings (N, 3) of a first-order sensor with the lag undone.

    tau: scalar or (3,) time constants, s; t: (N,) sample times, s.
    """
    tau = np.broadcast_to(np.asarray(tau, dtype=float), (3,))
    if not tau.any():
        return np.asarray(h, dtype=float)
    return np.asarray(h, dtype=float) + derivative(h, t) * tau


def delag_taps(t, tau):
    """(k, spacing) of the five-point difference delag(h, t, tau) adds, tau (4 D_m - D_2m) / 3
    = k (8 (n_+m - n_-m) - (n_+2m - n_-2m)), k = tau f_s / (12 m), m = spacing: what
    shared.honest.delag_share takes off the residuals' rms (desktop.methods.residuals).
    Per-axis taus: their rms (the residual along the field weighs the axes' noise by the
    field's direction, over the sphere alike)."""
    t = np.asarray(t, dtype=float)
    m = span_samples(t)
    rate = (len(t) - 1) / (t[-1] - t[0]) if len(t) > 1 and t[-1] > t[0] else 0.0
    tau_rms = math.sqrt(float(np.mean(np.square(np.broadcast_to(np.asarray(tau, dtype=float), (3,))))))
    return tau_rms * rate / (12.0 * m), m


def times(n, t=None, rate_hz=None):
    """The sample times (N,) s: t itself, or n samples at rate_hz; ValueError if neither."""
    if t is not None:
        t = np.asarray(t, dtype=float)
        if len(t) != n or not np.all(np.diff(t) > 0):
            raise ValueError("the time column must rise from row to row to de-lag the readings")
        return t
    if rate_hz is None:
        raise ValueError("de-lagging needs the sample times: give --rate SPS (or a log with a time column)")
    if not rate_hz > 0:
        raise ValueError("--rate must be a positive number of samples per second")
    return np.arange(n) / float(rate_hz)


def _algebraic(x, field=None):
    from desktop.methods.algebraic import fit_li_griffiths
    m, b, f = fit_li_griffiths(x, field=field)
    return np.asarray(m, dtype=float), np.asarray(b, dtype=float), float(f)


def _rms_residual(x, field=None):
    try:
        m, b, f = _algebraic(x, field)
    except (ValueError, np.linalg.LinAlgError):
        return float("inf")
    return float(np.sqrt(np.mean((np.linalg.norm((x - b) @ m.T, axis=1) - f) ** 2)))


def common_tau(h, d, field=None, start=None):
    """The common tau (s) that minimises the algebraic fit's residual rms of h + tau d; start
    (s): a configured tau, searched beside the grid's."""
    grid = GRID if start is None else np.unique(np.concatenate([GRID, [min(max(start, 0.0), TAU_MAX_S)]]))
    cost = [_rms_residual(h + tau * d, field) for tau in grid]
    i = int(np.argmin(cost))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    g = (math.sqrt(5.0) - 1.0) / 2.0
    a, c = hi - g * (hi - lo), lo + g * (hi - lo)
    fa, fc = _rms_residual(h + a * d, field), _rms_residual(h + c * d, field)
    for _ in range(20):                    # golden section: the bracket shrinks to 0.618^20 (1e-4) of it
        if fa < fc:
            hi, c, fc = c, a, fa
            a = hi - g * (hi - lo)
            fa = _rms_residual(h + a * d, field)
        else:
            lo, a, fa = a, c, fc
            c = lo + g * (hi - lo)
            fc = _rms_residual(h + c * d, field)
    return (a + c) / 2.0


_SYM = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def _jacobian(m, b, tau, h, d, f, d_check):
    """(residuals e (N,), J (N, 12): d e / d (M's 6, b's 3, tau's 3), Z: J with the taus'
    columns from d_check, the radial rate column (N,) from d_check)."""
    v = h + d * tau - b
    c = v @ m.T
    mag = np.linalg.norm(c, axis=1)
    u = c / mag[:, None]
    cols = []
    for j, k in _SYM:
        cols.append(u[:, j] * v[:, k] + (u[:, k] * v[:, j] if j != k else 0.0))
    um = u @ m                                     # d|c| / dx
    cols += [-um[:, i] for i in range(3)]
    instruments = cols + [um[:, i] * d_check[:, i] for i in range(3)]
    cols += [um[:, i] * d[:, i] for i in range(3)]
    md = d_check @ m.T
    rate_col = -np.sum(md * md, axis=1) / f        # d e / d kappa: the radial part of kappa y'' (docstring)
    return mag - f, np.column_stack(cols), np.column_stack(instruments), rate_col


def _solve(j, e, z, batch=None):
    """Instrumental-variable step (Z^T J) dp = -Z^T e and its covariance (Z^T J)^-1 S (J^T Z)^-1,
    the columns scaled to unit norm (they span 1e-3..1e5).

    Z is J with the taus' columns from the check span's derivative: J's own hold the
    de-lagging derivative's noise, which is in e too, and least squares would trade that
    noise against the lag, pulling tau low (1.7 % at 0.1 rev/s); Z's noise is not in e.
    S is the covariance of the score Z^T e: with batch (samples), :func:`score_covariance`;
    without, Z^T Z times e's variance (white residuals).
    """
    s = np.linalg.norm(j, axis=0)
    s[s == 0] = 1.0
    sz = np.linalg.norm(z, axis=0)
    sz[sz == 0] = 1.0
    js, zs = j / s, z / sz
    a = np.linalg.pinv(zs.T @ js)
    step = -(a @ (zs.T @ e)) / s
    meat = (zs.T @ zs) * float(e @ e) / max(1, len(e) - j.shape[1]) if batch is None else \
        score_covariance(zs, e, batch)
    cov = a @ meat @ a.T / np.outer(s, s)
    return step, cov


def score_covariance(z, e, batch):
    """The covariance (K, K) of the score z^T e (z (N, K), e (N,) in time order) from its sums
    over batches of batch samples: sum of S_b S_b^T plus each neighbouring pair's cross terms.

    De-lagging puts the derivative's noise tau n' into e, a few nT a sample (module
    docstring); summed against a smooth column it telescopes to each stretch's ends, and
    the ends of neighbouring batches cancel: the pairs' cross terms take that out, where
    batch sums alone would count every end (20 times the taus' spread on the Mag648 at
    0.5 rev/s). The batch (at least 0.1 s and 10 correlation times) keeps an error that
    follows the orientation within a batch and its neighbours. The sum is made positive
    semi-definite by clipping its eigenvalues at 0.
    """
    n = len(e) // batch
    if n < 10:
        zw = z * e[:, None]
        return zw.T @ zw
    sums = (z[:n * batch] * e[:n * batch, None]).reshape(n, batch, -1).sum(axis=1)
    tail = z[n * batch:].T @ e[n * batch:]
    sums[-1] += tail
    cross = sums[:-1].T @ sums[1:]
    meat = sums.T @ sums + cross + cross.T
    w, v = np.linalg.eigh((meat + meat.T) / 2.0)
    return (v * np.maximum(w, 0.0)) @ v.T


def estimate_response(h, t, field=None, prior=None):
    """Estimate the first-order response per axis from readings h (N, 3) nT at times t (N,) s.

    prior: a configured time constant (s), e.g. from the datasheet's bandwidth, or None. It
    seeds the search and is combined with the data's estimate as a Gaussian of
    PRIOR_SHARE of itself (:func:`with_prior`): where the data see the lag, they decide;
    where they do not (not identified), the configured tau stands with its uncertainty.

    Returns a dict: tau_s (3,) (clamped at 0), tau_sigma_s (3,), tau_cov_s2 (3, 3), common_tau_s, identified
    (each tau of the data alone at least SIGNIFICANT sigmas from 0), kappa_s2 and
    kappa_sigma_s2 (the second-order term, module docstring), kappa_nT (rms of |B| it
    explains), model_ok, tau_int (samples), rms (nT), prior_s (or None), data_tau_s and
    data_tau_sigma_s (the data's own estimate), and message (one line, or "" when all is well).
    """
    h = np.asarray(h, dtype=float)
    d = derivative(h, t)
    tau0 = common_tau(h, d, field, prior)
    m, b, f = _algebraic(h + tau0 * d, field)
    tau = np.full(3, tau0)
    d_check = derivative(h, t, CHECK_SPAN_S)
    for _ in range(GAUSS_NEWTON_STEPS):
        e, j, z, _ = _jacobian(m, b, tau, h, d, f, d_check)
        step, _ = _solve(j, e, z)
        dm = np.zeros((3, 3))
        for (a, c), s in zip(_SYM, step[:6]):
            dm[a, c] = dm[c, a] = s
        m, b, tau = m + dm, b + step[6:9], tau + step[9:12]
    e, j, z, rate_col = _jacobian(m, b, tau, h, d, f, d_check)
    tau_int = max(1.0, integrated_time(e)[0])
    full = np.column_stack([j, rate_col])
    batch = max(span_samples(t, 0.1), int(10 * tau_int))
    step, cov = _solve(full, e, np.column_stack([z, rate_col]))
    resid = e + full @ step
    # kappa's significance: the white covariance scaled to the residuals' long-run variance
    # as a fit's sums see it (long_run_ratio: the derivative's noise telescopes)
    ratio = long_run_ratio(resid, batch)
    white = float(resid @ resid) / max(1, len(e) - full.shape[1])
    scale = (tau_int if ratio is None else ratio * ratio) * white / (float(e @ e) / max(1, len(e) - full.shape[1]))
    sig = np.sqrt(np.maximum(np.diag(cov) * scale, 0.0))
    # the taus' covariance in the first-order model, without kappa: kappa's radial term
    # -kappa |h'|^2 / F has the shape of a common tau's, tau^2 |h'|^2 / 2F, and beside it
    # the common tau would look unknown (0.3 ms on the Mag649, where its estimate moves by
    # 0.005 ms from one noise to another)
    _, tau_cov = _solve(j, e, z, batch)
    tau_cov = tau_cov[9:12, 9:12]
    kappa, kappa_sigma = float(step[12]), float(sig[12])
    # what the term explains beyond the ellipsoid and the taus (its mean part is the scale's)
    kappa_nT = math.sqrt(max(0.0, float(np.mean(e * e)) - float(np.mean(resid * resid))))
    tau_sigma = np.sqrt(np.maximum(np.diag(tau_cov), 0.0))
    identified = bool(np.all(tau > SIGNIFICANT * tau_sigma))
    model_ok = not (abs(kappa) > SIGNIFICANT * kappa_sigma and kappa_nT > RESPONSE_MODEL_NT)
    out = {"tau_s": np.maximum(tau, 0.0), "tau_sigma_s": tau_sigma, "tau_cov_s2": tau_cov, "common_tau_s": tau0,
           "identified": identified, "kappa_s2": kappa, "kappa_sigma_s2": kappa_sigma, "kappa_nT": kappa_nT,
           "model_ok": model_ok, "tau_int": tau_int, "rms": float(np.sqrt(np.mean(e * e))), "prior_s": prior,
           "data_tau_s": tau.copy(), "data_tau_sigma_s": tau_sigma}
    if prior is not None:
        # an estimate that does not see the lag is no Gaussian about it (near 0 the radial
        # term goes as tau^2: the linear sigma says nothing): the configured tau stands alone
        tau, tau_cov = with_prior(tau, tau_cov, prior) if identified else \
            (np.full(3, prior), np.eye(3) * (PRIOR_SHARE * prior) ** 2)
        out.update(tau_s=np.maximum(tau, 0.0), tau_cov_s2=tau_cov,
                   tau_sigma_s=np.sqrt(np.maximum(np.diag(tau_cov), 0.0)))
    out["message"] = response_message(out)
    return out


def with_prior(tau, cov, prior):
    """(taus (3,), covariance (3, 3)) of the data's estimate tau with covariance cov (s, s^2)
    combined with a configured tau prior (s) held to PRIOR_SHARE of itself on each axis, in
    the Kalman form tau + K (prior - tau), K = cov (cov + P)^-1, which stays finite when the
    data say nothing (cov without bound) and when the prior is exact (P = 0)."""
    p = np.eye(3) * (PRIOR_SHARE * prior) ** 2
    gain = cov @ np.linalg.pinv(cov + p)
    post = cov - gain @ cov
    return tau + gain @ (np.full(3, prior) - tau), (post + post.T) / 2.0


def response_message(r):
    """One line on what the estimate cannot say, or ""."""
    words = []
    if not r["model_ok"]:
        words.append("the response is not first order: after de-lagging, the residuals still follow the squared "
                     "turn rate (%.2f nT rms, second-order term %.3g +- %.2g ms^2), which a first-order model "
                     "cannot represent" % (r["kappa_nT"], r["kappa_s2"] * 1e6, r["kappa_sigma_s2"] * 1e6))
    if not r["identified"] and r.get("prior_s") is None:
        words.append("the lag was not seen (tau %s ms): the sensor was turned too slowly for its response "
                     "to show; give it with --lag TAU_S or --lag-prior TAU_S, or turn faster"
                     % _taus_ms(r["tau_s"], r["tau_sigma_s"]))
    elif not r["identified"]:
        words.append("the lag was not seen (the data's tau %s ms): the sensor was turned too slowly for its "
                     "response to show; the configured %.3f ms kept, +- %.0f %%"
                     % (_taus_ms(r["data_tau_s"], r["data_tau_sigma_s"]), 1e3 * r["prior_s"], 100 * PRIOR_SHARE))
    return "; ".join(words)


def _taus_ms(taus, sigmas):
    return ", ".join("%.3f +- %.3f" % (1e3 * a, 1e3 * s) for a, s in zip(taus, sigmas))


def tau_error(h, t, tau, tau_cov, field=None, directions=4000):
    """The full-sphere error (nT) that the taus' uncertainty leaves in the calibration.

    The taus move together far more freely than apart (a common error moves |B| by its
    square, a difference between axes at first order: module docstring), so they are moved
    along each principal axis of their covariance tau_cov (3, 3) s^2 by its sigma; each time
    the calibration is refitted (the algebraic fit) and compared with tau's own over the
    whole sphere (readings b + M^-1 F u, u uniform), both scaled to det M = 1 as the
    streaming core's are (a fitted field leaves the scale free); the three in quadrature.
    """
    tau = np.asarray(tau, dtype=float)
    m, b, f = _algebraic(delag(h, t, tau), field)
    u = np.random.default_rng(0).standard_normal((directions, 3))
    raw = b + (f * u / np.linalg.norm(u, axis=1, keepdims=True)) @ np.linalg.inv(m).T
    w, v = np.linalg.eigh(np.asarray(tau_cov, dtype=float))
    total = 0.0
    for k in range(3):
        if not w[k] > 0:
            continue
        m2, b2, _ = _algebraic(delag(h, t, tau + v[:, k] * math.sqrt(w[k])), field)
        diff = np.linalg.norm((raw - b2) @ m2.T, axis=1) * (np.linalg.det(m) / np.linalg.det(m2)) ** (1 / 3) - f
        total += float(np.mean(diff * diff))
    return math.sqrt(total)


def long_run_ratio(r, batch):
    """sqrt(long-run variance / variance) of residuals r in time order, from their sums over
    batches of batch samples with their neighbours' cross terms (:func:`score_covariance`),
    or None with fewer than 10 batches.

    De-lagging adds the derivative's noise tau n', whose sum over any stretch telescopes
    to its ends: it is in every residual but barely in a fitted parameter. The core's
    predicted error (white residuals) and its widening by tau_int >= 1
    (desktop.methods.residuals) would count it in full; the long-run variance counts what a
    fit's sums keep: the white part as it is, a correlated part widened by its correlation
    time (the batch at least 10 tau_int long), the differenced part hardly at all. Batch
    means alone count each batch's ends (0.34 of the variance on the Mag648 at 0.5 rev/s in
    batches of 0.1 s, 0.21 in batches of 1 s; with the cross terms 0.19 and 0.18), and
    predicted twice its real full-sphere error on 120 s.
    """
    r = np.asarray(r, dtype=float)
    if len(r) // batch < 10:
        return None
    var = float(np.var(r))
    if not var > 0:
        return None
    centred = r - r.mean()
    lr = float(score_covariance(np.ones((len(r), 1)), centred, batch)[0, 0]) / len(r)
    return math.sqrt(max(lr, var / len(r)) / var)
