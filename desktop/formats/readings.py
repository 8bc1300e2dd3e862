"""Raw readings in nT from a magnetometer log or a capture, and corrected CSV.

    h = read_raw("log.csv", LogFormat(columns="mx,my,mz", unit="G"))    # (N, 3) nT
    h, t = read_log("log.csv", LogFormat(unit="counts", scale=8.33, skip=2))   # t: (N,) s or None

A text log (CSV or whitespace-separated, with or without a header: logtext.py) is
converted here from its unit to nT. Every failure is a FormatError with one line
naming the file and the problem.
"""

import os

import numpy as np

from desktop.formats import FormatError
from desktop.formats.capture import load_field_nT
from desktop.formats.logtext import field_columns, numbers, read_table, time_column

MIN_ROWS = 12  # nine parameters need more than nine samples
# No magnetometer fluxcal calibrates reads 10 mT: the Earth's field is 22,000-67,000 nT,
# a fluxgate's range ~100,000-1,000,000 nT, and a calibration's offset is bounded at
# 8.4 mT (shared/calibration.py). A larger value is a wrong unit or a broken file, and
# refused here, before numpy's overflow warnings in a fit (1e300 squared is inf).
MAX_ABS_NT = 1e7
# What one unit of a log is in nT; counts need the sensor's nT per count (LogFormat.scale).
UNITS_NT = {"nT": 1.0, "uT": 1e3, "mG": 100.0, "G": 1e5, "counts": None}
# The Earth's field is 22,000-67,000 nT and an uncalibrated magnetometer reads it within a
# few tens of percent: a median |B| below this is a log in another unit (gauss reads ~0.5,
# microtesla ~50, milligauss ~500, a MEMS chip's counts 500-5000), not one in nT.
MIN_MEDIAN_NT = 5000.0
EARTH_NT = (22000.0, 67000.0)


class LogFormat:
    """How to read a text log.

    columns: "X,Y,Z" as header names or 0-based indices (None: found by name, logtext.py);
    unit: a key of UNITS_NT; scale: nT per count (unit counts only); skip: lines before the
    header or the data; time_column: a name or index (None: a column named t, time, sec, ...).
    """

    def __init__(self, columns=None, unit="nT", scale=None, skip=0, time_column=None):
        if unit not in UNITS_NT:
            raise FormatError("--unit must be one of %s, not %r" % ("|".join(UNITS_NT), unit))
        if unit == "counts" and scale is None:
            raise FormatError("--unit counts needs --scale NT_PER_COUNT (the sensor's nT per count, "
                              "from its datasheet)")
        if scale is not None and unit != "counts":
            raise FormatError("--scale applies to --unit counts only (%s is already a field unit)" % unit)
        if scale is not None and not (np.isfinite(scale) and scale > 0):
            raise FormatError("--scale must be a positive number of nT per count")
        if skip < 0:
            raise FormatError("--skip must be a number of lines >= 0")
        self.columns, self.unit, self.scale, self.skip, self.time_column = columns, unit, scale, skip, time_column

    def nT_per_unit(self):
        return self.scale if self.unit == "counts" else UNITS_NT[self.unit]

    def is_default(self):
        return (self.columns, self.unit, self.scale, self.skip, self.time_column) == (None, "nT", None, 0, None)


def read_raw(path, fmt=None):
    """(N, 3) float64 raw readings in nT from a text log (LogFormat) or a .npz capture."""
    return read_log(path, fmt)[0]


def read_log(path, fmt=None):
    """(h, t): h (N, 3) float64 raw readings in nT, t (N,) seconds or None (no time column).

    A .npz capture's time is its own (formats.capture); a text log's comes from
    fmt.time_column or a column named like time (logtext.time_column).
    """
    fmt = fmt or LogFormat()
    if not os.path.exists(path):
        raise FormatError("%s: no such file" % path)
    if path.endswith(".npz"):
        if not fmt.is_default():
            raise FormatError("%s: a capture .npz carries its own columns, unit and time: "
                              "--columns, --unit, --scale, --skip and --time-column are for text logs" % path)
        h, t = load_field_nT(path), None
    else:
        h, t = _read_text(path, fmt)
    if h.ndim != 2 or h.shape[1] != 3:
        raise FormatError("%s: expected three columns x, y, z" % path)
    if len(h) < MIN_ROWS:
        raise FormatError("%s: %d rows, need at least %d" % (path, len(h), MIN_ROWS))
    bad = ~np.isfinite(h).all(axis=1)
    if bad.any():
        raise FormatError("%s: row %d is not finite (NaN or inf)" % (path, int(np.argmax(bad)) + 1))
    big = (np.abs(h) > MAX_ABS_NT).any(axis=1)
    if big.any():
        row = int(np.argmax(big))
        raise FormatError("%s: row %d holds %.6g nT, beyond any magnetometer's range (|value| <= %.0e nT): %s"
                          % (path, row + 1, h[row][np.argmax(np.abs(h[row]))], MAX_ABS_NT, _unit_hint(fmt)))
    _check_magnitude(path, h, fmt)
    return h, t


def _read_text(path, fmt):
    table = read_table(path, fmt.skip)
    cols = field_columns(table, fmt.columns)
    names = ",".join(table.names[c] for c in cols) if table.names else "columns %d,%d,%d" % tuple(cols)
    h = numbers(table, cols, names) * fmt.nT_per_unit()
    found = time_column(table, fmt.time_column)
    if found is None:
        return h, None
    col, seconds = found
    try:
        return h, numbers(table, [col], "the time column %s" % (table.names[col] if table.names else col))[:, 0] * seconds
    except FormatError:
        if fmt.time_column is not None:
            raise
        return h, None    # a column named like time that holds dates, not seconds: not used


def _unit_hint(fmt):
    if fmt.unit == "counts":
        return "check --scale (nT per count, from the sensor's datasheet)"
    return "is the log in %s? (give its unit with --unit %s)" % (fmt.unit, "|".join(UNITS_NT))


def _check_magnitude(path, h, fmt):
    """One line naming the likely unit when |B| is far below any field on Earth."""
    median = float(np.median(np.linalg.norm(h, axis=1)))
    if median >= MIN_MEDIAN_NT:
        return
    raw = median / fmt.nT_per_unit()
    # the unit that puts the log's |B| near the Earth's field, within a factor of two
    guess = [u for u, k in UNITS_NT.items() if k and u != fmt.unit and EARTH_NT[0] / 2 <= raw * k <= 2 * EARTH_NT[1]]
    if fmt.unit == "counts":
        hint = "check --scale (nT per count, from the sensor's datasheet)"
    elif guess:
        hint = "the numbers look like %s: add --unit %s" % (guess[0], guess[0])
        if guess[0] != "G":    # a MEMS chip's counts fall in the same decades
            hint += " (raw counts: --unit counts --scale NT_PER_COUNT)"
    else:
        hint = "raw counts? add --unit counts --scale NT_PER_COUNT"
    raise FormatError("%s: median |B| is %.4g nT read as %s, far below the Earth's field (%.0f-%.0f nT): %s"
                      % (path, median, fmt.unit, EARTH_NT[0], EARTH_NT[1], hint))


def write_corrected(path, corrected):
    """CSV with x,y,z,magnitude in nT."""
    mag = np.linalg.norm(corrected, axis=1)
    try:
        np.savetxt(path, np.column_stack([corrected, mag]), delimiter=",", header="x,y,z,magnitude",
                   comments="", fmt="%.4f")
    except OSError as exc:
        raise FormatError("%s: %s" % (path, exc.strerror or exc))
