"""The coverage map as text, readable without colour, and the words that guide the turning.

    lines = map_lines(counts, edge, cap, now=(dx, dy, dz))   # axis labels, the map, the legend
    guidance(counts, edge)        # "largest gap: 40 % of the sphere around -Z, towards +X: point ..."
    watch = TurnWatch()
    watch.add(t, direction, coverage); watch.warning()       # "not turning: ..." or None

Each square of the map (desktop/views/sphere.py: equal area, +Z on top, -Z at
the bottom, longitude about Z across) shows the firmware's coverage cell under
it by a glyph of its own, so the map reads the same in colour, without colour
(NO_COLOR) and in a log: GLYPHS below. A terminal may colour them by STYLES.
"""

import math

from desktop.views.sphere import SphereMap, describe, largest_gap

EMPTY, SOME, FULL, NOW, GAP = ".", "+", "#", "@", "*"
STYLES = {EMPTY: "grey50", SOME: "yellow", FULL: "green", NOW: "bold magenta", GAP: "bold cyan"}
LABEL_W = 4      # the column of row labels left of the map
ALONG = "along the Earth's field"
HEMISPHERES = "north and down in the northern hemisphere, north and up in the southern"

_MAPS = {}


def sphere_map(edge, cols=48, rows=12):
    key = (edge, cols, rows)
    if key not in _MAPS:
        _MAPS[key] = SphereMap(edge, cols, rows)
    return _MAPS[key]


def map_rows(counts, edge, cap, now=None, cols=48, rows=12):
    """The map's squares as rows of glyphs (EMPTY, SOME, FULL; NOW where the sensor points,
    GAP at the middle of the largest gap)."""
    m = sphere_map(edge, cols, rows)
    cap = max(1, cap or max(counts) or 1)
    out = [[EMPTY if not counts[c] else FULL if counts[c] >= cap else SOME for c in row] for row in m.cell]
    gap = largest_gap(counts, edge)
    if gap is not None and gap.centre is not None:
        r, c = m.position(*gap.centre)
        out[r][c] = GAP
    if now is not None and any(now):
        r, c = m.position(*now)
        out[r][c] = NOW
    return out


def axis_labels(cols=48):
    """The line over the map naming the longitudes of -X, -Y, +X, +Y, -X (left to right)."""
    line = [" "] * (LABEL_W + cols + 2)
    for lon, name in ((-180, "-X"), (-90, "-Y"), (0, "+X"), (90, "+Y"), (180, "-X")):
        col = LABEL_W + min(cols - 1, int((lon + 180.0) / 360.0 * cols))
        start = min(max(0, col - 1 if lon < 180 else col), len(line) - 2)
        line[start:start + 2] = list(name)
    return "".join(line).rstrip()


def row_label(row, rows):
    if row == 0:
        return "+Z".ljust(LABEL_W)
    if row == rows - 1:
        return "-Z".ljust(LABEL_W)
    if row == rows // 2:
        return "z=0".ljust(LABEL_W)
    return " " * LABEL_W


def legend(cap):
    return ["%s full (%d samples)   %s some   %s empty   %s the sensor now   %s middle of the largest gap"
            % (FULL, cap, SOME, EMPTY, NOW, GAP),
            "equal-area map: each square the same share of the sphere. A square at +Z fills while the"
            " sensor's +Z axis points %s (%s)." % (ALONG, HEMISPHERES)]


def map_lines(counts, edge, cap, now=None, cols=48, rows=12):
    """The whole picture as plain lines: longitude labels, the map with row labels, the legend."""
    grid = map_rows(counts, edge, cap, now, cols, rows)
    lines = [axis_labels(cols)]
    lines += [row_label(r, rows) + "".join(row) for r, row in enumerate(grid)]
    return lines + legend(cap or max(counts) or 1)


def guidance(counts, edge):
    """One line naming the largest empty region and the turn that fills it."""
    gap = largest_gap(counts, edge)
    if gap is None:
        return "every cell holds samples"
    if gap.centre is None:
        return "nothing covered yet: turn the sensor slowly about every axis"
    where = describe(gap.centre)
    axis = where.split(",")[0]
    return "largest gap: %.0f %% of the sphere around %s: point the sensor's %s axis %s" % (
        100.0 * gap.fraction, where, axis, ALONG)


class TurnWatch:
    """Whether the operator is turning the sensor, from the directions and the coverage it reports.

    Held still, a hand wobbles a degree or two; a coverage cell is 90/n degrees
    wide (22.5 at the default n = 4). STILL_DEG in STILL_S seconds is under 2
    degrees a second: at that rate a new cell is a dozen seconds away, so the
    operator is told to turn. Coverage that has not grown for STALE_S seconds
    while the sensor turns means it turns through cells already seen."""

    STILL_DEG = 5.0
    STILL_S = 3.0
    STALE_S = 8.0

    def __init__(self):
        self.anchor = None          # the direction the current still spell started at
        self.still_since = None
        self.coverage = None
        self.grown_at = None
        self.t = None

    def add(self, t, direction, coverage):
        """At time t (s): the sensor's direction (or None when the device does not say), the coverage 0..1."""
        self.t = t
        if direction is not None and any(direction):
            n = math.sqrt(sum(c * c for c in direction))
            d = [c / n for c in direction]
            if self.anchor is None or _angle(self.anchor, d) > self.STILL_DEG:
                self.anchor = d
                self.still_since = t
        if self.coverage is None or coverage > self.coverage:
            self.coverage = coverage
            self.grown_at = t

    def still_s(self):
        return 0.0 if self.still_since is None else self.t - self.still_since

    def warning(self):
        """A line telling the operator to turn, or None while the turning finds new orientations."""
        if self.t is None:
            return None
        if self.still_since is not None and self.still_s() >= self.STILL_S:
            return ("NOT TURNING: the sensor has pointed the same way for %.0f s; turn it slowly about every axis"
                    % self.still_s())
        if self.t - self.grown_at >= self.STALE_S:
            return ("no new orientation for %.0f s: the turns go over cells already seen; turn towards the gap"
                    % (self.t - self.grown_at))
        return None


def _angle(u, v):
    dot = max(-1.0, min(1.0, u[0] * v[0] + u[1] * v[1] + u[2] * v[2]))
    return math.degrees(math.acos(dot))
