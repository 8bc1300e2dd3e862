"""Text views shared by the device commands: a calibration's figures, ages, the coverage map.

Not a command (COMMANDS does not list it).
"""

import time

SOURCES = {
    "json": "loaded from the stored file",
    "tmp": "recovered from the half-written cal.tmp",
    "bak": "recovered from the backup cal.bak",
    "new": "made or set since boot",
}
FACES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")


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


def cell_directions(edge):
    """Unit vectors to the centres of shared/coverage.py's 6 n^2 cells, in its cell order."""
    import math

    tans = [math.tan(math.radians(-45.0 + 90.0 * (k + 0.5) / edge)) for k in range(edge)]
    # per face: the axis it is centred on, its sign, and the axes of its cell coordinates i, j
    faces = ((0, 1, 1, 2), (0, -1, 1, 2), (1, 1, 0, 2), (1, -1, 0, 2), (2, 1, 0, 1), (2, -1, 0, 1))
    out = []
    for major, sign, pi, qj in faces:
        for i in range(edge):
            for j in range(edge):
                v = [0.0, 0.0, 0.0]
                v[major], v[pi], v[qj] = float(sign), tans[i], tans[j]
                n = math.sqrt(sum(c * c for c in v))
                out.append([c / n for c in v])
    return out


def coverage_rows(counts, edge, cap, marks=" .:o#"):
    """The sphere's cube-face cells (shared/coverage.py) as text rows: six n x n faces side by side.

    Each face is drawn with its second cell coordinate upwards; a cell shows
    how full it is, from `marks[0]` (empty) to `marks[-1]` (at the cap).
    Returns rows of (mark, fill 0..1), None between faces.
    """
    cap = max(1, cap or max(counts) or 1)
    rows = []
    for j in reversed(range(edge)):
        row = []
        for face in range(6):
            for i in range(edge):
                fill = min(1.0, counts[(face * edge + i) * edge + j] / cap)
                row.append((_mark(fill, marks), fill))
            row.append(None)   # gap between faces
        rows.append(row[:-1])
    return rows


def _mark(fill, marks):
    if fill <= 0:
        return marks[0]
    if fill >= 1:
        return marks[-1]
    return marks[1 + int(fill * (len(marks) - 2))]


def coverage_text(counts, edge, cap):
    """The coverage map as plain text lines (for a log, or a terminal without colours)."""
    head = "".join(f.ljust(2 * edge + 1) for f in FACES).rstrip()
    out = [head]
    for row in coverage_rows(counts, edge, cap):
        out.append("".join(" " if c is None else c[0] * 2 for c in row))
    return out
