"""A magnetometer log as text: comma-, semicolon- or tab-separated, or columns split by
whitespace, with or without a header line, after any number of metadata lines.

    table = read_table(path, skip=0)               # Table: header names (or None), rows of fields
    cols = field_columns(table, "mx,my,mz")        # three 0-based indices; None: found by name
    xyz = numbers(table, cols)                     # (N, 3) float64 in the log's own unit
    found = time_column(table, None)               # (index, seconds per unit), or None: no time column

The csv module splits delimited lines (quotes and spaces after a comma handled), str.split
whitespace-separated ones, and numpy converts the chosen columns. Every failure is a
FormatError with one line naming the file and the problem, and what to pass to fix it.
"""

import csv
import re

import numpy as np

from desktop.formats import FormatError

DELIMITERS = ",;\t"
# Column names that are a field component along an axis: "x", "mx", "bx", "mag_x", "flux_a_x_nT",
# "compass_x_gauss", "Magnetic Field x"; an accelerometer's or gyroscope's ("ax", "gx") are not,
# and beside a name with one of _FIELD_WORDS a bare axis ("acc_x", "gyro_x") is not taken either.
_AXIS_PREFIXES = ("m", "b", "h", "mag", "field", "compass", "flux")
_FIELD_WORDS = ("m", "b", "h", "mag", "magn", "magnetic", "magnetometer", "field", "compass", "flux", "fluxgate",
                "nt", "ut", "gauss", "mg")
# Column names of time, as loggers write them, and the unit their suffix says (default s).
TIME_NAMES = ("t", "time", "sec", "secs", "second", "seconds", "timestamp", "ts", "elapsed")
TIME_UNITS = {"ms": 1e-3, "millis": 1e-3, "msec": 1e-3, "us": 1e-6, "micros": 1e-6, "s": 1.0, "sec": 1.0}


class Table:
    """A log's lines split into fields: names (header, or None) and rows [(line number, fields)]."""

    def __init__(self, path, names, rows):
        self.path = path
        self.names = names
        self.rows = rows

    @property
    def width(self):
        return len(self.names) if self.names else len(self.rows[0][1])


def read_table(path, skip=0):
    """The log at path, its first `skip` lines left out; blank lines and '#' comments ignored."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as exc:
        raise FormatError("%s: %s" % (path, exc.strerror or exc))
    if b"\0" in raw:
        raise FormatError("%s: not a text file" % path)
    try:
        text = raw.decode("utf-8-sig")     # a spreadsheet's byte-order mark is not part of the first name
    except UnicodeDecodeError:
        text = raw.decode("latin-1")       # a logger's own 8-bit text, e.g. a unit in its header
    lines = text.splitlines()
    numbered = [(i + 1, s) for i, s in enumerate(lines) if i >= skip and s.strip() and not s.lstrip().startswith("#")]
    if not numbered:
        raise FormatError("%s: empty file" % path + (" after skipping %d lines" % skip if skip else ""))
    first = numbered[0][1]
    delimiter = next((d for d in DELIMITERS if d in first), None)
    if delimiter is None:
        split = [(n, s.split()) for n, s in numbered]
    else:
        reader = csv.reader((s for _, s in numbered), delimiter=delimiter, skipinitialspace=True)
        split = [(n, [f.strip() for f in fields]) for (n, _), fields in zip(numbered, reader)]
    head = split[0][1]
    if len(head) < 3:
        more = next((k for k, (n, f) in enumerate(split) if len(f) >= 3), None)
        hint = ("; skip the lines before the columns with --skip %d" % (split[more][0] - 1)) if more is not None else ""
        raise FormatError("%s: line %d has %d field%s (%r), a magnetometer log needs three columns%s"
                          % (path, split[0][0], len(head), "" if len(head) == 1 else "s", first.strip()[:40], hint))
    if all(_is_number(f) for f in head):
        return Table(path, _commented_header(lines, numbered[0][0], delimiter, len(head)), split)
    if len(split) == 1:
        raise FormatError("%s: no data rows" % path)
    return Table(path, head, split[1:])


def _commented_header(lines, first, delimiter, width):
    """Names in a '#' line just before the data (numpy.savetxt's header), or None."""
    above = lines[first - 2].strip() if first >= 2 else ""
    if not above.startswith("#"):
        return None
    text = above.lstrip("#").strip()
    names = next(csv.reader([text], delimiter=delimiter, skipinitialspace=True)) if delimiter else text.split()
    names = [n.strip() for n in names]
    return names if len(names) == width and not all(_is_number(n) for n in names) else None


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True


def _tokens(name):
    return [t for t in re.split(r"[^a-z0-9]+", name.lower()) if t]


def _column(table, spec, what):
    """One column given as a 0-based index or a header name (case ignored)."""
    spec = spec.strip()
    if spec.isdigit():
        k = int(spec)
        if k >= table.width:
            raise FormatError("%s: %s column %d, but the log has %d columns (0..%d)"
                              % (table.path, what, k, table.width, table.width - 1))
        return k
    if table.names is None:
        raise FormatError("%s: the log has no header line, so the %s column %r cannot be found by name: give "
                          "0-based indices (e.g. --columns 0,1,2)" % (table.path, what, spec))
    lower = [n.lower() for n in table.names]
    if spec.lower() not in lower:
        raise FormatError("%s: no %s column %r; the header has %s" % (table.path, what, spec, ",".join(table.names)))
    return lower.index(spec.lower())


def field_columns(table, spec=None):
    """The three 0-based columns of x, y, z: from spec ("mx,my,mz" or "3,4,5"), else by name."""
    if spec:
        parts = spec.split(",")
        if len(parts) != 3:
            raise FormatError("--columns takes three names or 0-based indices X,Y,Z, not %r" % spec)
        return [_column(table, p, "field") for p in parts]
    if table.names is None:
        if table.width == 3:
            return [0, 1, 2]
        raise FormatError("%s: %d columns and no header: say which hold x, y, z with --columns X,Y,Z "
                          "(0-based indices)" % (table.path, table.width))
    cols = []
    for axis in "xyz":
        found = [k for k, n in enumerate(table.names) if _axis_match(n, axis)]
        # a name that says it is the field ("mag_x") over one that only says the axis ("gyro_x")
        named = [k for k in found if _axis_match(table.names[k], axis) == 2]
        found = named if len(named) == 1 else found
        if len(found) != 1:
            why = "no column" if not found else "columns %s" % ",".join(table.names[k] for k in found)
            raise FormatError("%s: %s for %s in the header (%s): name the field's columns with --columns X,Y,Z"
                              % (table.path, why, axis, ",".join(table.names)))
        cols.append(found[0])
    return cols


def _axis_match(name, axis):
    """2: a field's component along axis ("mx", "mag_x", "flux_a_x_nT"); 1: only the axis ("x",
    "gyro_x"); 0: neither."""
    tokens = _tokens(name)
    if any(p + axis in tokens for p in _AXIS_PREFIXES):          # "mx", "magx"
        return 2
    if axis in tokens:
        return 2 if set(tokens) & set(_FIELD_WORDS) else 1
    return 0


def time_column(table, spec=None):
    """(0-based column, seconds per unit) of the time: spec, else a header name such as t, time,
    sec, timestamp (time_ms in ms); None when there is none."""
    if spec:
        k = _column(table, spec, "time")
    else:
        if table.names is None:
            return None
        k = next((k for k, n in enumerate(table.names) if _tokens(n)[:1] and _tokens(n)[0] in TIME_NAMES), None)
        if k is None:
            return None
    tokens = _tokens(table.names[k]) if table.names else []
    per = next((TIME_UNITS[t] for t in tokens[1:] if t in TIME_UNITS), 1.0)
    return k, per


def numbers(table, cols, what="x,y,z"):
    """(N, len(cols)) float64 of those columns; a missing or non-numeric field names its line (the
    first in the file that has either)."""
    try:
        return np.array([[fields[c] for c in cols] for _, fields in table.rows], dtype=float).reshape(-1, len(cols))
    except (IndexError, ValueError):
        pass
    for line, fields in table.rows:
        if len(fields) <= max(cols):
            raise FormatError("%s: line %d has fewer columns than the header (column %d needed)"
                              % (table.path, line, max(cols)))
        if not all(_is_number(fields[c]) for c in cols):
            raise FormatError("%s: line %d: expected numbers in %s" % (table.path, line, what))
    raise FormatError("%s: expected numbers in %s" % (table.path, what))    # a field numpy refused and float() took
