"""Quick re-calibration: the previous calibration's shape, today's offsets and gain.

    cal = fit.solve(prior=previous)      # shared.fit.EllipsoidFit; FitError as ever
    cal.diagnostics["mode"]              # "quick", or "reshaped" when the shape moved

Over a survey day what moves in a fluxgate is its offsets (sensor and front
end drift with temperature) and the gain common to its axes (the ADC's
reference); the shape, axis angles and gain ratios, stays. With A_prev the
previous calibration's quadric for today's field (A = M^T M / F^2,
shared.quadric eq. 1) the fit keeps A = s A_prev and moves s and b only: four
parameters, which a partial rotation (wrist twists, 10-30 % of the sphere)
determines where the nine of a full fit are not (README, "Quick
re-calibration"). The field is the previous one (same site): a change of the
fitted radius is the common gain.

Unless the data say otherwise. The nine-parameter fit with the previous
calibration as a weak prior (shared.prior) is solved on the same sums; under
an unchanged shape the likelihood ratio N log(RSS_quick / RSS_full) is
chi^2 with 5 degrees of freedom, so above its 0.1 % point (20.5) the shape has
moved and that fit is returned instead (mode "reshaped").

Predicted error: the four-parameter posterior covariance (shared.solver) and
the previous calibration's own predicted error, which its shape carries into
this one, added in quadrature.

Never worse: the previous calibration on today's samples misfits by
stale_rms. Its error over the sphere is about sqrt(e_prev^2 + stale_rms^2 -
rms^2), its own error and what the drift added; a re-calibration predicted
to be no better raises FitError(not_better), so the previous one stays.
"""

import math

from shared.prior import make_prior
from shared.quadric import FRAC
from shared.solver import (DEGENERATE_COVERAGE, FitError, _State, _finish, _quantise, iterate, log_ratio, setup,
                           solve_state)

NOT_BETTER = "not_better"
# chi^2 with 5 degrees of freedom (the shape's five beyond the gain): P(> 20.52) = 0.001
SHAPE_LR = 20.52
# What a day may move: offsets by tens of nT (real fluxgates ~1 nT/C), the common
# gain by 1e-3 (the ADS1292's reference, 45 ppm/C [DS 6.5]). Wide: the data decide.
QUICK_OFFSET_NT = 50.0
QUICK_GAIN = 2e-3


class _GainAndOffsets:
    """The quick fit's four directions: the gain scales the quadric as a whole
    (d a = c a), the offsets move freely."""

    @staticmethod
    def directions(st):
        return [[float(x) for x in st.a] + [0.0, 0.0, 0.0],
                [0.0] * 6 + [1.0, 0.0, 0.0],
                [0.0] * 6 + [0.0, 1.0, 0.0],
                [0.0] * 6 + [0.0, 0.0, 1.0]]

    @staticmethod
    def apply(st, step):
        # a (1 + c) in integers: the shape stays the previous one to the last bit
        # whatever the float width that computed c (shared.solver's fixed point)
        c = _quantise(step[0])
        return [(a * c) >> FRAC for a in st.a_int], [_quantise(x) for x in step[1:]]


def _rms(pb, rss, field):
    # residual (1) is |h_c|^2/F^2 - 1 ~ 2 (|h_c| - F)/F
    return math.sqrt(max(0.0, float(pb.value(rss, -6 * FRAC)) / float(pb.nf))) / 2.0 * field


def solve(sums, prior, field=None, num=float, scale=1.0, shape_sigma=(0.01, 0.0175), min_samples=12,
          max_iter=60, max_error=None, refuse_worse=True):
    """Quick re-calibration from the power sums; see the module docstring."""
    if field is None:
        field = prior.field
    pb, k_nom, kr, observability = setup(sums, field, num, scale, min_samples)
    n = pb.n
    pr = make_prior(pb, prior, field, num, kr, k_nom, shape_sigma, QUICK_OFFSET_NT, 2.0 * QUICK_GAIN)
    stale = _State(pb, pr, [_quantise(x) for x in pr.a_frame], [_quantise(x) for x in pr.f_target])
    st, h, iterations, rejected = iterate(pb, pr, stale, num, max_iter, _GainAndOffsets)
    dirs = _GainAndOffsets.directions(st)
    cal = _finish(pb, pr, st, field, num, kr, k_nom, observability, iterations, float("inf"), h, dirs)
    d = cal.diagnostics
    d["rejected"] = rejected
    d["mode"] = "quick"
    prev_error = float(prior.diagnostics.get("predicted_error") or 0.0)
    d["prior_error"] = prev_error
    d["predicted_error"] = math.sqrt(d["predicted_error"] ** 2 + prev_error ** 2)
    stale_rms = _rms(pb, stale.rss, field)

    # The shape test: the full fit, weakly tied to the previous calibration.
    try:
        full, full_st = solve_state(sums, field, prior, num, scale, shape_sigma, min_samples, max_iter,
                                    float("inf"))
        ratio = log_ratio(st.rss, full_st.rss)
        lr = n * ratio if ratio is not None else 0.0
    except FitError:
        full, lr = None, 0.0
    d["shape_lr"] = lr
    if full is not None and lr > SHAPE_LR:
        full.diagnostics["mode"] = "reshaped"
        full.diagnostics["shape_lr"] = lr
        cal = full
        d = cal.diagnostics

    d["stale_rms"] = stale_rms
    limit = max_error if max_error is not None else 0.01 * float(cal.field)
    if d["predicted_error"] > limit:
        raise FitError(DEGENERATE_COVERAGE, "predicted calibration error %.3g exceeds %.3g: rotate through more orientations"
                       % (d["predicted_error"], limit))
    stale_error = math.sqrt(prev_error ** 2 + max(0.0, stale_rms ** 2 - d["rms"] ** 2))
    d["stale_error"] = stale_error
    if refuse_worse and d["predicted_error"] >= stale_error:
        raise FitError(NOT_BETTER, "predicted error %.3g is not below the previous calibration's %.3g on these samples: it stays"
                       % (d["predicted_error"], stale_error))
    return cal
