"""Whether a calibration may be used: the acceptance thresholds, for a finished session and set-cal alike.

    problem = check_calibration(cal, cfg, k)   # None, or (reason, message) of the first that fails

cal is in input units of k nT each (per axis): a session's sums (k = scale / window)
or ADC codes (set-cal, k = scale). The reasons are stable codes (docs/protocol.md);
the message says what to do. In order: the fit's residual (max_rms_nt), how well
the rotation observed the parameters (min_observability; a quick re-calibration is
exempt, it takes its shape from the calibration before), the predicted error
(max_predicted_nt; the message tells a sensor that lags the turn from a field that moves
by the residuals' correlation with the turn rate), the fitted field against field_nt, and each axis' gain against the
configured front end.
"""

from shared import codes


def _number(d, key):
    # diagnostics may come from a set-cal request: only a number counts
    v = d.get(key)
    return v if isinstance(v, (int, float)) and not isinstance(v, bool) else None


def _cause(d):
    """Why the predicted error is high, and what to do about it (desktop/methods/refusal.py alike)."""
    rho = _number(d, "residual_rho")
    if rho is None or rho <= 0.5:
        return "independent residuals: turn for longer, through more orientations"
    turn = _number(d, "residual_turn_corr")
    why = "the residuals follow each other (rho %.2f" % rho
    if turn is None:      # a calibration from before the turn was counted (set-cal)
        return why + "): the sensor lags the turn (check sensor_bandwidth_hz) or the field moves"
    # a lag reads |h| short by B (tau w)^2 / 2: the residuals fall as the turn speeds up
    if turn < -0.3:
        return why + ", with the turn rate %.2f): the sensor lags the turn (check sensor_bandwidth_hz): turn slower" % turn
    return why + ", with the turn rate %.2f): the field or iron near it moves; turning slower will not help" % turn


def check_calibration(cal, cfg, k):
    """Physical and statistical sanity of a calibration on inputs of k nT/unit."""
    d = cal.diagnostics
    rms = _number(d, "rms")
    if rms is not None and rms > cfg["max_rms_nt"]:
        return (codes.RMS_TOO_HIGH, "fit residual %.2f nT > %.2f nT: hold the sensor away from iron and rotate smoothly"
                % (rms, cfg["max_rms_nt"]))
    obs = _number(d, "observability")
    # a quick re-calibration takes its shape from the previous one: a cap is what it is for
    if obs is not None and obs < cfg["min_observability"] and d.get("mode") != codes.QUICK:
        return (codes.POOR_OBSERVABILITY, "observability %.3f < %.3f: rotate about all three axes"
                % (obs, cfg["min_observability"]))
    pe = _number(d, "predicted_error")
    if pe is not None and pe > cfg["max_predicted_nt"]:
        return (codes.PREDICTED_ERROR_TOO_HIGH, "predicted full-sphere error %.2f nT > %.2f nT (max_predicted_nt): %s"
                % (pe, cfg["max_predicted_nt"], _cause(d)))
    f0 = cfg["field_nt"]
    if f0:
        if abs(cal.field / f0 - 1.0) > cfg["field_tol"]:
            return (codes.FIELD_OUT_OF_RANGE, "fitted field %.0f nT, configured %.0f nT +- %.0f %%: check the site or scale_x/y/z"
                    % (cal.field, f0, 100 * cfg["field_tol"]))
    # Gains within 25 % of the configured front end: anything else is a wrong
    # scale setting or a broken channel, not a calibration.
    m = cal.matrix
    for i in range(3):
        g = m[i][i] / k[i]
        if not 0.75 < g < 1.25:
            return (codes.BAD_SCALE, "axis %s gain %.3f of nominal: check scale_%s and the front end"
                    % ("xyz"[i], g, "xyz"[i]))
    return None
