"""Text views shared by the device commands: a calibration's figures and ages.

Not a command (COMMANDS does not list it).
"""

import time

SOURCES = {
    "json": "loaded from the stored file",
    "tmp": "recovered from the half-written cal.tmp",
    "bak": "recovered from the backup cal.bak",
    "new": "made or set since boot",
}


def format_age(seconds):
    if seconds is None:
        return "at an unknown time (the board has no clock)"
    for unit, size in (("days", 86400), ("h", 3600), ("min", 60)):
        if seconds >= 2 * size:
            return "%.1f %s ago" % (seconds / size, unit)
    return "%.0f s ago" % seconds


def calibration_age(cal, status=None):
    """Seconds since a calibration record (dict) was made: its RTC time, else this boot's uptime."""
    meta = cal.get("meta") or {}
    if meta.get("time"):
        return max(0.0, time.time() - meta["time"])
    if status and status.get("cal_source") == "new" and meta.get("uptime_ms") is not None:
        return max(0.0, (status["uptime_ms"] - meta["uptime_ms"]) / 1000.0)
    return None


def predicted_text(nt):
    """The predicted full-sphere error as every command prints it."""
    return "predicted full-sphere error %.3f nT" % nt


def _figure(d, key, fmt):
    v = d.get(key)
    return None if v is None else fmt % v


def fit_figures(d):
    """One line of a fit's figures from a calibration's diagnostics or a `cal` result event."""
    parts = [_figure(d, "field", "field %.2f nT"),
             _figure(d, "rms", "residual rms %.3f nT"),
             None if d.get("predicted_error") is None else predicted_text(d["predicted_error"]),
             _figure(d, "observability", "observability %.3f"),
             _figure(d, "n", "%d samples")]
    if d.get("coverage") is not None:
        parts.append("coverage %.0f %%" % (100 * d["coverage"]))
    if d.get("lag_left_nt") is not None:
        # the board did not de-lag (delag or delag_adc off): device/session.py _widen
        parts.append("warning: the lag was not undone (delag off), which may leave up to %.3f nT the predicted "
                     "error does not count" % d["lag_left_nt"])
    return ", ".join(p for p in parts if p)


def calibration_lines(cal, status=None):
    """Lines describing a calibration record (dict, as get-cal sends it)."""
    meta = cal.get("meta") or {}
    figures = dict(cal.get("diagnostics") or {}, field=cal.get("field"))
    lines = [fit_figures(figures)]
    made = []
    if meta.get("temperature_c") is not None:
        made.append("at %.1f C" % meta["temperature_c"])
        if status and status.get("temp") is not None:
            made[-1] += " (now %.1f C)" % status["temp"]
    made.append(format_age(calibration_age(cal, status)))
    if meta.get("source"):
        made.append("source %s" % meta["source"])
    if meta.get("firmware"):
        made.append("firmware %s" % meta["firmware"])
    lines.append("made " + ", ".join(made))
    return lines
