"""A walked survey's readings as traverses with positions from the markers and the pace.

    lines, grid = read_survey("survey.npz", cal=None)     # cal: a shared.calibration.Calibration

Input: the capture `fluxcal simulate --motion survey` or `fluxcal survey` writes (desktop/formats/capture.py):
the raw codes of every conversion, their times, `line_marks` (the marker pressed at
each traverse's start and end) and the grid in config["survey"] (width_m east,
length_m north, spacing_m, zigzag). With a calibration the readings are corrected
(h_c = M (h - b)) before their magnitude is taken; without one |B| is the nominal
front end's, as an uncalibrated fluxgate reads.

Positions come as MagMap2000 places them (survey-practice.md s.1): the reading at a
line's first marker is at the line's start, the one at its last marker at its end,
and the readings between are spread evenly in time (the walker kept the pace).
The conversions are then averaged into samples every `sample_m` along the line
(8 per metre, a Grad601's densest setting), each at its bin's centre. A recording of
`fluxcal survey` has its |B| already (f_nT, the handheld's blocks, 10 a second by default).
"""

import numpy as np

from desktop.formats import FormatError
from desktop.formats.calibration import to_nT_units
from desktop.formats.capture import field_nT, load_capture


class Traverse:
    """One walked line: samples along it. Arrays (S,): north_m, nT, t_s; east_m a float."""

    def __init__(self, index, east_m, north_m, nT, t_s, northward):
        self.index, self.east_m, self.northward = index, float(east_m), bool(northward)
        self.north_m, self.nT, self.t_s = north_m, nT, t_s


class Grid:
    """The survey's grid: width_m (east), length_m (north), spacing_m, zigzag, origin at (0, 0)."""

    handheld_calibrated = False     # the readings are |B| a calibrated handheld computed

    def __init__(self, width_m, length_m, spacing_m, zigzag):
        self.width_m, self.length_m = float(width_m), float(length_m)
        self.spacing_m, self.zigzag = float(spacing_m), bool(zigzag)


def survey_grid(cap, path="survey"):
    cfg = cap.get("config") or {}
    s = cfg.get("survey") if isinstance(cfg, dict) else None
    if not s or "line_marks" not in cap:
        raise FormatError("%s: not a walked survey (no line markers or grid; record one with "
                          "fluxcal simulate --motion survey)" % path)
    grid = Grid(s["width_m"], s["length_m"], s["spacing_m"], s["zigzag"])
    # a recording's |B| is the handheld's, with the calibration it had in force (fluxcal survey)
    grid.handheld_calibrated = bool(cfg.get("handheld_calibrated")) and "f_nT" in cap
    return grid


def magnitudes(cap, cal=None):
    """(N,) |B| of every reading, nT: corrected by `cal` (nT or code units) if given. A recording
    of `fluxcal survey` holds |B| as the handheld computed it (f_nT, its calibration in force):
    that, unless `cal` asks for the codes to be corrected here."""
    if "f_nT" in cap and cal is None:
        return np.asarray(cap["f_nT"], dtype=float)
    h = field_nT(cap)
    if np.isnan(h).any():
        raise FormatError("%d readings of this recording came from the handheld's flash log, which keeps |B| "
                          "only: --cal needs the codes (map it without --cal)" % np.isnan(h).any(axis=1).sum())
    if cal is not None:
        cal = to_nT_units(cal, cap["nT_per_code"])
        h = (h - np.asarray(cal.offset)) @ np.asarray(cal.matrix).T
    return np.linalg.norm(h, axis=1)


def read_survey(path, cal=None, sample_m=0.125):
    """(list of Traverse, Grid) from a survey capture file."""
    cap = load_capture(path)
    grid = survey_grid(cap, path)
    return traverses(cap["t"], magnitudes(cap, cal), cap["line_marks"], grid, sample_m), grid


def traverses(t, mag, line_marks, grid, sample_m=0.125):
    """Traverses from readings (t (N,) s, mag (N,) nT), markers (L, 2) s and the grid."""
    marks = np.asarray(line_marks, dtype=float)
    if marks.ndim != 2 or marks.shape[1] != 2 or np.any(marks[:, 1] <= marks[:, 0]):
        raise FormatError("line markers must be (start, end) pairs in time order")
    n_bins = max(int(round(grid.length_m / sample_m)), 1)
    edges = np.linspace(0.0, grid.length_m, n_bins + 1)
    centres = 0.5 * (edges[1:] + edges[:-1])
    out = []
    for i, (t0, t1) in enumerate(marks):
        sel = (t >= t0) & (t <= t1)
        if sel.sum() < n_bins:
            raise FormatError("line %d has %d readings for %d samples: too few" % (i + 1, sel.sum(), n_bins))
        northward = not grid.zigzag or i % 2 == 0
        along = (t[sel] - t0) / (t1 - t0) * grid.length_m          # the pace: readings spread evenly
        north = along if northward else grid.length_m - along
        k = np.clip(np.searchsorted(edges, north, side="right") - 1, 0, n_bins - 1)
        count = np.bincount(k, minlength=n_bins)
        if np.any(count == 0):
            raise FormatError("line %d: readings too sparse for %.3f m samples" % (i + 1, sample_m))
        nT = np.bincount(k, weights=mag[sel], minlength=n_bins) / count
        ts = np.bincount(k, weights=t[sel], minlength=n_bins) / count
        out.append(Traverse(i, (i + 0.5) * grid.spacing_m, centres.copy(), nT, ts, northward))
    return out
