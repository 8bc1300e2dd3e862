"""Quick re-calibration: the previous calibration's shape, today's offsets and gain.

    cal = fit.solve(prior=previous)      # shared.fit.EllipsoidFit; FitError as ever
    cal.diagnostics["mode"]              # "quick", or "reshaped" when the shape moved

Over a survey day what moves in a fluxgate is its offsets (sensor and front
end drift with temperature) and its gains together (the ADC's reference); the
shape, axis angles and gain ratios, stays. With A_prev the previous
calibration's quadric for today's field (A = M^T M / F^2, shared.quadric eq. 1)
the fit keeps A = s A_prev and moves s and b only: four parameters. Gains
that move apart are tried next, each kept only when the likelihood ratio
against the simpler model passes chi^2's 0.1 % point: one per ADS1292 (X and Y
on one chip, Z on the other, each with its own reference) and one per axis
(the fluxgate's own gain coefficients): GAIN_MODELS. Four to six parameters,
which a partial rotation (wrist twists, 10-30 % of the sphere) determines
where the nine of a full fit are not (README, "Quick re-calibration"). The
field is the previous one (same site): a change of the fitted radius is a
gain.

Unless the data say otherwise. The nine-parameter fit with the previous
calibration as a weak prior (shared.prior) is solved on the same sums; under
an unchanged shape the likelihood ratio N log(RSS_quick / RSS_full) is
chi^2 with 6 less the gains' degrees of freedom, so above its 0.1 % point the shape has
moved and that fit is returned instead (mode "reshaped").

Predicted error: the posterior covariance of the parameters fitted (shared.predicted) and
the previous calibration's own predicted error, which its shape carries into
this one, added in quadrature.

Never worse: the previous calibration on today's samples misfits by
stale_rms. Its error over the sphere is about sqrt(e_prev^2 + stale_rms^2 -
rms^2), its own error and what the drift added; a re-calibration predicted
to be no better raises FitError(not_better), so the previous one stays.
"""

import math

from shared.codes import DEGENERATE_COVERAGE, NOT_BETTER
from shared.errors import FitError
from shared.iteration import MAX_ITER, PROVISIONAL_ITER, State, iterate, log_ratio, quantise
from shared.prior import SHAPE_SIGMA, make_prior
from shared.quadric import FRAC, PAIR
from shared.result import MAX_ERROR_SHARE, finish
from shared.solver import MIN_OBSERVABILITY, MIN_SAMPLES, setup, solve_problem

# the 0.1 % points of chi^2 with 0..5 degrees of freedom: a model with more gains against
# one with fewer; the full fit's shape (six) against the gains fitted
CHI2_001 = (0.0, 10.83, 13.82, 16.27, 18.47, 20.52)
# What a day may move: offsets by tens of nT (real fluxgates ~1 nT/C), the common
# gain by 1e-3 (the ADS1292's reference, 45 ppm/C [DS 6.5]). Wide: the data decide.
QUICK_OFFSET_NT = 50.0
# rms turn (rad) of the samples' directions below which nothing is determined: a
# steady instrument's noise cluster, not a rotation (a 1 % cap is ~0.1)
MIN_TURN = 0.02
QUICK_GAIN = 2e-3


# The gains that may move, nested, each tried only when the one before it is not enough:
# one common gain; one per ADS1292 (X and Y on one chip, Z on the other, each with its own
# reference, device/ads1292.py); one per axis (a fluxgate's own gain coefficients, up to
# 20 ppm/C per axis in the simulator's model). Axis i's gain is group groups[i]'s.
GAIN_MODELS = ((0, 0, 0), (0, 0, 1), (0, 1, 2))


class _GainsAndOffsets:
    """The quick fit's directions: each gain group scales its axes (raw axis gains
    D turn A into D^-1 A D^-1, so d a_ij = -(e_i + e_j) a_ij for small e), the
    offsets move freely."""

    def __init__(self, groups):
        k = max(groups) + 1
        # per direction, how many of each quadric term's two axes are in the group
        self.counts = [[(groups[i] == g) + (groups[j] == g) for i, j in PAIR] for g in range(k)]

    def directions(self, st):
        out = [[float(c * x) for c, x in zip(cs, st.a)] + [0.0, 0.0, 0.0] for cs in self.counts]
        for i in range(3):
            row = [0.0] * 9
            row[6 + i] = 1.0
            out.append(row)
        return out

    def apply(self, st, step):
        # a (1 + c) in integers, per term: the shape within each group stays the previous
        # one to the last bit, whatever the float width that computed c (shared.solver)
        k = len(self.counts)
        cs = [quantise(x) for x in step[:k]]
        da = []
        for m in range(6):
            c = 0
            for g in range(k):
                c += self.counts[g][m] * cs[g]
            da.append((st.a_int[m] * c) >> FRAC)
        return da, [quantise(x) for x in step[k:]]


def _rms(pb, rss, field):
    # residual (1) is |h_c|^2/F^2 - 1 ~ 2 (|h_c| - F)/F
    return math.sqrt(max(0.0, float(pb.value(rss, -6 * FRAC)) / float(pb.nf))) / 2.0 * field


def solve(sums, prior, field=None, num=float, scale=1.0, shape_sigma=SHAPE_SIGMA, min_samples=MIN_SAMPLES,
          max_iter=MAX_ITER, max_error=None, refuse_worse=True, models=GAIN_MODELS, independent=1.0,
          between=None):
    """Quick re-calibration from the power sums; see the module docstring.

    independent: the share of the samples that count as independent, (1 - rho) / (1 + rho)
    for residuals with lag-1 correlation rho (device/session.py measures it): the
    likelihood ratios scale with it, so correlated residuals do not pass for a moved shape.
    between: None, or called between the stages (each gain model, the shape test) and their
    iterations: a device drains its DRDY ring there, as the whole outlasts the ring on a Pico.
    """
    if field is None:
        field = prior.field
    problem = setup(sums, field, num, scale, min_samples)
    pb, k_nom, kr, observability = problem
    n = pb.n
    pr = make_prior(pb, prior, field, num, kr, k_nom, shape_sigma, QUICK_OFFSET_NT, 2.0 * QUICK_GAIN)
    # the samples must have turned: their spread against the radius (both in the frame)
    top = 0.0
    for i in range(3):
        top = max(top, float(pb.cov[i][i]))
    turn = math.sqrt(top * (pr.a_frame[0] + pr.a_frame[1] + pr.a_frame[2]) / 3.0)
    if not turn >= MIN_TURN:
        raise FitError(DEGENERATE_COVERAGE, "the samples turned by %.1f degrees rms: turn the instrument"
                       % math.degrees(turn))
    stale = State(pb, pr, [quantise(x) for x in pr.a_frame], [quantise(x) for x in pr.f_target])
    stale_rms = _rms(pb, stale.rss, field)
    # a provisional estimate (a device's, every few seconds while collecting) skips the
    # shape test, a whole nine-parameter fit; the final solve runs it
    provisional = max_iter <= PROVISIONAL_ITER
    # one common gain first; a gain per ADC, then per axis, only where the data ask for them
    basis = _GainsAndOffsets(models[0])
    st, h, iterations, rejected = iterate(pb, pr, stale, num, max_iter, basis, between)
    gains_lr = 0.0
    for groups in models[1:]:
        more = _GainsAndOffsets(groups)
        if between is not None:
            between()
        st2, h2, it2, rej2 = iterate(pb, pr, st, num, max_iter, more, between)
        ratio = log_ratio(st.rss, st2.rss)
        lr = n * independent * ratio if ratio is not None else 0.0
        iterations += it2
        rejected += rej2
        if lr > CHI2_001[len(more.counts) - len(basis.counts)]:
            basis, st, h, gains_lr = more, st2, h2, lr
    # what the shape test does not need is garbage before it builds its states (a board's heap)
    stale = st2 = h2 = more = None
    dirs = basis.directions(st)
    cal = finish(pb, pr, st, field, num, kr, k_nom, observability, iterations, float("inf"), h, dirs)
    d = cal.diagnostics
    d["rejected"] = rejected
    d["mode"] = "quick"
    d["gains"] = len(basis.counts)   # 1 common, 2 per chip, 3 per axis
    d["gains_lr"] = gains_lr
    prev_error = float(prior.diagnostics.get("predicted_error") or 0.0)
    d["prior_error"] = prev_error
    d["predicted_error"] = math.sqrt(d["predicted_error"] ** 2 + prev_error ** 2)
    rss = st.rss
    st = h = dirs = None

    # The shape test: the full fit, weakly tied to the previous calibration.
    try:
        if provisional:
            raise FitError(NOT_BETTER, "no shape test for a provisional estimate")
        if between is not None:
            between()
        full, full_st = solve_problem(problem, field, prior, num, shape_sigma, max_iter, float("inf"),
                                      MIN_OBSERVABILITY, between)
        ratio = log_ratio(rss, full_st.rss)
        lr = n * independent * ratio if ratio is not None else 0.0
    except FitError:
        full, lr = None, 0.0
    d["shape_lr"] = lr
    if full is not None and lr > CHI2_001[6 - len(basis.counts)]:
        full.diagnostics["mode"] = "reshaped"
        full.diagnostics["shape_lr"] = lr
        cal = full
        d = cal.diagnostics

    d["stale_rms"] = stale_rms
    limit = max_error if max_error is not None else MAX_ERROR_SHARE * float(cal.field)
    if d["predicted_error"] > limit:
        raise FitError(DEGENERATE_COVERAGE, "predicted full-sphere error %.3g nT exceeds %.3g nT: rotate through more orientations"
                       % (d["predicted_error"], limit))
    stale_error = math.sqrt(prev_error ** 2 + max(0.0, stale_rms ** 2 - d["rms"] ** 2))
    d["stale_error"] = stale_error
    if refuse_worse and d["predicted_error"] >= stale_error:
        raise FitError(NOT_BETTER, "predicted full-sphere error %.3g nT is not below the previous calibration's %.3g nT on these samples: it stays"
                       % (d["predicted_error"], stale_error))
    return cal
