"""Temperature coefficients of a calibration: offsets and per-axis gains per C.

    from shared.tempco import fit_tempco, attach
    tc = fit_tempco([cal_cold, cal_warm])   # calibrations with meta["temperature_c"]
    cal = attach(cal_warm, tc)              # the record, compensated: cal.at_temperature(t)

The firmware runs this (two calibrations at two temperatures, device/app.py).
From one long warm-up instead: shared/warmup.py (the desktop's; not on the board).

The model (shared/calibration.py, docs/temperature.md): with tau = T - t0 the
raw offset is b + o tau and raw axis i's gain (1 + g_i tau) times its gain at
t0, so h_c = M diag(1 / (1 + g tau)) (h - b - o tau).

Where the numbers come from. A calibration's quadric is A = M^T M / F^2 (F the
record's field: the known one, or the fitted radius; A does not depend on
which). Raw axis gains D = diag(1 + g tau) turn the sensor's quadric A_ref into
D^-1 A_ref D^-1, whatever rotation the symmetric M of each fit carries, so
sqrt(A_ref,ii / A_ii) = 1 + g_i tau: the diagonal alone gives each raw axis's
gain against the reference, and a change of the fitted radius at one site is
the common gain (the ADC's reference moves every axis of its chip together).
Offsets are read directly. Least-squares lines of both against temperature
give o and g.

Arithmetic for 32-bit and 30-bit floats: everything is a difference from the
first calibration (offsets through their exact integer parts, gains as ratios
minus 1, temperatures about their mean), never an absolute of 48,000 nT or of
millions of codes.

Assumptions (refused where they can be checked): one sensor, one site (a
changed field reads as a common gain), the same input unit, a temperature that
moved by MIN_SPAN_C or more. A quick re-calibration (shape from the previous
one) carries the offsets and the common gain only; per-axis gains need full
calibrations.
"""

import math

from shared.calibration import Calibration

MIN_SPAN_C = 2.0        # a line through less is noise
MAX_GAIN_STEP = 0.05    # gains that differ by more between records: another unit or sensor


def gain_ratio(cal, ref):
    """(3,) gain of each raw axis of cal relative to ref, minus 1: sqrt(A_ref,ii / A_ii) - 1."""
    f = cal.field / ref.field
    out = []
    for i in range(3):
        a = cal.matrix[0][i] ** 2 + cal.matrix[1][i] ** 2 + cal.matrix[2][i] ** 2
        a_ref = ref.matrix[0][i] ** 2 + ref.matrix[1][i] ** 2 + ref.matrix[2][i] ** 2
        q = (a_ref / a) * f * f
        out.append((q - 1.0) / (math.sqrt(q) + 1.0))   # sqrt(q) - 1 without cancelling
    return out


def offset_step(cal, ref):
    """(3,) cal's offset minus ref's: integer parts in integers, then the fractions."""
    return [(cal._b_int[i] - ref._b_int[i]) + (cal._b_frac[i] - ref._b_frac[i]) for i in range(3)]


def weighted_lines(ts, ys, ws):
    """Weighted least-squares lines y_k = c + s (t - tm) of columns ys[k][0..2] against ts;
    returns (tm, [c0, c1, c2], [s0, s1, s2])."""
    sw = 0.0
    for w in ws:
        sw += w
    tm = 0.0
    for t, w in zip(ts, ws):
        tm += w * t
    tm /= sw
    stt = 0.0
    for t, w in zip(ts, ws):
        stt += w * (t - tm) * (t - tm)
    cs = []
    ss = []
    for i in range(3):
        ym = 0.0
        sty = 0.0
        for t, y, w in zip(ts, ys, ws):
            ym += w * y[i]
            sty += w * (t - tm) * y[i]
        cs.append(ym / sw)
        ss.append(sty / stt)
    return tm, cs, ss


def _span_check(temps, what):
    lo = min(temps)
    hi = max(temps)
    distinct = []
    for t in temps:
        if t not in distinct:
            distinct.append(t)
    if len(distinct) < 2 or hi - lo < MIN_SPAN_C:
        raise ValueError("%s span %.2f C (%d distinct temperatures): temperature coefficients need two or more"
                         " temperatures at least %.1f C apart" % (what, hi - lo, len(distinct), MIN_SPAN_C))
    return lo, hi


def tempco_record(tm, b_lines, g_lines, t0, lo, hi, sources, method):
    """The record from lines of offset steps and gain ratios about tm, referred to t0."""
    o = b_lines[1]
    g = []
    for i in range(3):
        r0 = g_lines[0][i] + g_lines[1][i] * (t0 - tm)    # gain ratio - 1 at t0
        g.append(g_lines[1][i] / (1.0 + r0))              # relative to the gain at t0
    return {"t0_c": t0, "offset_per_c": o, "gain_per_c": g, "range_c": [lo, hi], "sources": sources,
            "method": method}


def fit_tempco(cals, t0_c=None, weights=None):
    """The tempco record from two or more calibrations of one sensor at one site.

    cals: Calibrations (full or quick) with meta["temperature_c"], in one input unit.
    t0_c: the reference temperature; default the last calibration's (the record the
        coefficients will be attached to; attach() re-refers them to any other).
    weights: one per calibration for the lines (default equal).
    Refuses (ValueError) fewer than two temperatures, a span under MIN_SPAN_C, a
    missing temperature, mixed units and gains that differ by more than 5 %.
    """
    if len(cals) < 2:
        raise ValueError("temperature coefficients need two or more calibrations, got %d" % len(cals))
    temps = []
    units = cals[0].meta.get("units")
    for k, c in enumerate(cals):
        t = c.meta.get("temperature_c")
        if t is None:
            raise ValueError("calibration %d has no meta.temperature_c" % k)
        if c.meta.get("units") != units:
            raise ValueError("calibration %d is in %r, calibration 0 in %r: one input unit"
                             % (k, c.meta.get("units"), units))
        temps.append(float(t))
    lo, hi = _span_check(temps, "the calibrations'")
    ref = cals[0]
    gs = []
    bs = []
    for k, c in enumerate(cals):
        r = gain_ratio(c, ref)
        for i in range(3):
            if abs(r[i]) > MAX_GAIN_STEP:
                raise ValueError("calibration %d's axis %d gain differs by %.3g from calibration 0's:"
                                 " not the same sensor, unit or site" % (k, i, r[i]))
        gs.append(r)
        bs.append(offset_step(c, ref))
    ws = [1.0] * len(cals) if weights is None else [float(w) for w in weights]
    t0 = temps[-1] if t0_c is None else float(t0_c)
    tm, bc, bsl = weighted_lines(temps, bs, ws)
    _, gc, gsl = weighted_lines(temps, gs, ws)
    return tempco_record(tm, (bc, bsl), (gc, gsl), t0, lo, hi, len(cals), "calibrations")


def attach(cal, tempco):
    """A copy of cal carrying tempco, referred to cal's own meta["temperature_c"] (the
    temperature its matrix and offset are for). Offsets' slopes do not change; a gain
    coefficient g about t0 is g / (1 + g (t1 - t0)) about t1."""
    t1 = cal.meta.get("temperature_c")
    if t1 is None:
        raise ValueError("the calibration has no meta.temperature_c to refer the coefficients to")
    tc = dict(tempco)
    d = float(t1) - tc["t0_c"]
    tc["gain_per_c"] = [g / (1.0 + g * d) for g in tc["gain_per_c"]]
    tc["t0_c"] = float(t1)
    return Calibration(cal.matrix, cal.offset, cal.field, cal.diagnostics, cal.meta, tc, cal.response)
