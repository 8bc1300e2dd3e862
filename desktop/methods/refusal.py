"""The one predicted error of a fit on the laptop, and whether the fit stands: when not, its
cause and the fix that fits the cause.

    honest = predicted_error(cal, h, pinned)            # nT; written into cal.diagnostics
    reason, message, lifted = problem(cal, h, honest, 5.0)   # or None: the fit stands

`fluxcal fit` and `fluxcal report` both call predicted_error, so a file gets one figure:
the core's (shared/predicted.py, white residuals) widened by the residuals' correlation in
time, with a systematic floor (desktop/methods/residuals.py). A fit predicted worse than
--max-predicted is refused (predicted_error_too_high) unless the user accepts it; when the
cause is the coverage (degenerate_coverage), or the figure is beyond MAX_ERROR_SHARE of the
field for want of coverage, --accept-anyway does not lift the refusal.

The cause, in this order:
- coverage: the samples' observability (the spread's smallest / largest eigenvalue) below
  the firmware's acceptance minimum: turning about all axes is the fix;
- lag: correlated residuals that follow the square of the turn rate (desktop/methods/turn_rate.py,
  the check the report's verdict makes too). A sensor (or an ADC
  window) that lags a turning field reads |h| low by B (tau w)^2 / 2
  (desktop/methods/residuals.py), so its residuals fall as the rate w grows; turning more
  slowly is the fix. A MEMS chip's errors follow the orientation instead (correlation ~0 on
  the recordings in ../shared/data/real, -0.92 for the Mag648 turned by hand in docs/simulator.md);
- correlated: residuals that follow each other but not the rate: errors of the orientation
  or the time (a sensor not linear to within its noise, iron that moves with it, a field that
  changes), which turning more slowly does not remove;
- noise: white residuals, too many of them for the samples to average.
"""

import math

from desktop.methods import correct_array
from desktop.methods.residuals import honest_error
from desktop.methods.turn_rate import rate_effect
from shared.codes import DEGENERATE_COVERAGE, PREDICTED_ERROR_TOO_HIGH, QUICK
from shared.result import MAX_ERROR_SHARE

# tau_int above this (samples): the residuals are correlated, not white
CORRELATED_TAU = 3.0
# device/config.py's min_observability default (tests/test_fit_causes.py holds them equal)
MIN_OBSERVABILITY = 0.02
# A correlation with the squared rate that counts as the lag's: at least this, and three
# standard errors of a correlation over N / tau_int independent samples
LAG_CORRELATION = 0.3


def predicted_error(cal, h, pinned, delag=None):
    """The predicted full-sphere error (nT) of cal fitted to h ((N, 3) nT, time order), or None;
    delag: (k, spacing) where h was de-lagged (residuals.residual_stats).

    Writes it into cal.diagnostics (predicted_error; predicted_error_white: the core's,
    for independent residuals; tau_int; residual_white_rms: the sample-to-sample noise;
    systematic_floor) and returns residuals.honest_error's dict.
    """
    honest = honest_error(cal, h, pinned, delag)
    if honest["predicted_error"] is not None:
        if honest["delag_share"] < 1.0:
            cal.diagnostics["delag_share"] = round(honest["delag_share"], 4)
        cal.diagnostics.update(predicted_error=honest["predicted_error"],
                               predicted_error_white=honest["predicted_error_white"], tau_int=honest["tau_int"],
                               residual_white_rms=honest["white"], systematic_floor=honest["applied_floor"])
    return honest


def rate_correlation(cal, h):
    """Correlation of the residuals |h_c| - F, less their direction's mean, with the squared turn
    rate of h_c (per sample): desktop/methods/turn_rate.py's, as the report's verdict finds it."""
    effect = rate_effect(correct_array(cal, h), cal.field)
    return 0.0 if effect is None else effect.correlation


def cause(cal, h, honest):
    """(name, words saying the cause and its fix) for a fit whose predicted error is too high."""
    d = cal.diagnostics
    obs = d.get("observability")
    # a quick re-calibration takes its shape from the calibration before: a cap is what it is for
    if obs is not None and obs < MIN_OBSERVABILITY and d.get("mode") != QUICK:
        return "coverage", ("the samples cover too little of the sphere (observability %.3f < %.2f): "
                            "rotate about all three axes" % (obs, MIN_OBSERVABILITY))
    tau = honest["tau_int"]
    if tau > CORRELATED_TAU:
        corr = rate_correlation(cal, h)
        significant = max(LAG_CORRELATION, 3.0 / math.sqrt(max(1.0, len(h) / tau)))
        if corr < -significant:
            return "lag", ("the residuals fall as the turn rate grows (correlation %.2f with its square): "
                           "the sensor lags the rotation, turn more slowly" % corr)
        return "correlated", ("the residuals (%.3g nT rms, sample-to-sample noise %.3g nT) follow each other over "
                              "%.0f samples but not the turn rate (correlation %.2f): errors that follow the orientation "
                              "or the time (a sensor not linear to within its noise, iron moving with it, a changing "
                              "field), which turning more slowly will not remove: keep iron away, or expect no better "
                              "of this sensor" % (honest["rms"], honest["white"], tau, corr))
    return "noise", ("the noise (residual %.3g nT rms over %d samples, observability %.3f) is more than the samples "
                     "average out: record for longer, or with less noise" % (honest["rms"], len(h), obs or 0.0))


def problem(cal, h, honest, limit):
    """(reason, message, lifted) when the predicted error exceeds limit (nT, --max-predicted), or None.

    lifted: whether --accept-anyway may write it anyway. Not when the cause is the coverage:
    then (degenerate_coverage) also a limit above MAX_ERROR_SHARE of the field counts as that.
    """
    pe = honest["predicted_error"]
    if pe is None:
        return None
    hard = MAX_ERROR_SHARE * cal.field
    if not pe > min(limit, hard):
        return None
    name, words = cause(cal, h, honest)
    if name == "coverage":
        bar, which = (limit, "--max-predicted") if limit <= hard else (hard, "%.0f %% of the field" % (100 * MAX_ERROR_SHARE))
        return DEGENERATE_COVERAGE, ("predicted full-sphere error %.2f nT > %.2f nT (%s; a coverage failure, which "
                                     "--accept-anyway does not lift): %s" % (pe, bar, which, words)), False
    if not pe > limit:
        return None
    return PREDICTED_ERROR_TOO_HIGH, ("predicted full-sphere error %.2f nT > %.2f nT (--max-predicted): %s"
                                      % (pe, limit, words)), True
