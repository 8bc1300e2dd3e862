"""Raw readings in nT (a CSV with x,y,z columns, or a capture), and corrected CSV.

Every failure is a FormatError with one line naming the file and the problem.
"""

import csv
import os

import numpy as np

from desktop.formats import FormatError
from desktop.formats.capture import load_field_nT

MIN_ROWS = 12  # nine parameters need more than nine samples
# No magnetometer fluxcal calibrates reads 10 mT: the Earth's field is 22,000-67,000 nT,
# a fluxgate's range ~100,000-1,000,000 nT, and a calibration's offset is bounded at
# 8.4 mT (shared/calibration.py). A larger value is a wrong unit or a broken file, and
# refused here, before numpy's overflow warnings in a fit (1e300 squared is inf).
MAX_ABS_NT = 1e7


def read_raw(path):
    """(N, 3) float64 raw readings in nT from a CSV (header with x,y,z) or a .npz capture."""
    if not os.path.exists(path):
        raise FormatError("%s: no such file" % path)
    if path.endswith(".npz"):
        h = load_field_nT(path)
    else:
        h = _read_csv(path)
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
        raise FormatError("%s: row %d holds %.6g, beyond any magnetometer's range (|value| <= %.0e nT): "
                          "are the readings in nT?" % (path, row + 1, h[row][np.argmax(np.abs(h[row]))], MAX_ABS_NT))
    return h


def _read_csv(path):
    try:
        with open(path, newline="") as fh:
            reader = csv.reader(fh)
            header = next(reader, None)
            if header is None:
                raise FormatError("%s: empty file" % path)
            names = [c.strip().lower() for c in header]
            missing = [c for c in ("x", "y", "z") if c not in names]
            if missing:
                raise FormatError("%s: header has no column %s (need x,y,z in nT)" % (path, ",".join(missing)))
            cols = [names.index(c) for c in ("x", "y", "z")]
            rows = []
            for line_no, row in enumerate(reader, start=2):
                if not row or all(not c.strip() for c in row):
                    continue
                try:
                    rows.append([float(row[c]) for c in cols])
                except (ValueError, IndexError):
                    raise FormatError("%s: line %d: expected numbers in x,y,z" % (path, line_no))
    except UnicodeDecodeError:
        raise FormatError("%s: not a text CSV file" % path)
    except OSError as exc:
        raise FormatError("%s: %s" % (path, exc.strerror or exc))
    if not rows:
        raise FormatError("%s: no data rows" % path)
    return np.array(rows, dtype=float)


def write_corrected(path, corrected):
    """CSV with x,y,z,magnitude in nT."""
    mag = np.linalg.norm(corrected, axis=1)
    try:
        np.savetxt(path, np.column_stack([corrected, mag]), delimiter=",", header="x,y,z,magnitude",
                   comments="", fmt="%.4f")
    except OSError as exc:
        raise FormatError("%s: %s" % (path, exc.strerror or exc))
