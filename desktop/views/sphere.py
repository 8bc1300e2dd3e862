"""The sphere of directions as an operator reads it: an equal-area grid, the largest gap, its name.

    m = SphereMap(cells_per_edge=4, cols=48, rows=12)
    m.cell[row][col]            # the firmware's coverage cell under each grid square
    m.position(dx, dy, dz)      # (row, col) of a direction
    gap = largest_gap(counts, 4)        # Gap(cells, centre, fraction) or None when nothing is empty
    describe(gap.centre)        # "-Z, towards +X"

The grid is Lambert's cylindrical equal-area projection: columns are equal
steps of longitude about Z (0 at +X, 90 degrees at +Y), rows equal steps of z
(top +Z, bottom -Z). By Archimedes' hat-box theorem a band of the sphere has
an area proportional to its height in z, so every square covers the same solid
angle, 4 pi / (rows cols): how much of the map is empty is how much of the
sphere is. The cells are shared/coverage.py's (equal-angle cube-face cells,
within 1.2x of equal area), looked up with the firmware's own code.
"""

import math

from shared.coverage import Coverage

AXES = "XYZ"
# a second component at least this share of the first names a tilt towards it (tan 22.5 deg:
# the direction is nearer the 45 degree diagonal than the axis)
TILT = math.tan(math.radians(22.5))


def cell_centres(edge):
    """Unit vectors to the centres of shared/coverage.py's 6 n^2 cells, in its cell order."""
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


class SphereMap:
    """An equal-area grid of `rows` x `cols` squares over the sphere, each under one coverage cell."""

    def __init__(self, cells_per_edge=4, cols=48, rows=12):
        self.edge = cells_per_edge
        self.cols = cols
        self.rows = rows
        cov = Coverage(cells_per_edge)
        self.cell = [[cov.cell(*self.direction(r, c)) for c in range(cols)] for r in range(rows)]

    def direction(self, row, col):
        """Unit vector to the centre of square (row, col)."""
        z = 1.0 - 2.0 * (row + 0.5) / self.rows
        lon = math.radians(-180.0 + 360.0 * (col + 0.5) / self.cols)
        s = math.sqrt(max(0.0, 1.0 - z * z))
        return (s * math.cos(lon), s * math.sin(lon), z)

    def position(self, dx, dy, dz):
        """(row, col) of the square holding direction (dx, dy, dz), any length but zero."""
        n = math.sqrt(dx * dx + dy * dy + dz * dz)
        if not n > 0:
            raise ValueError("zero direction has no place on the map")
        row = min(self.rows - 1, int((1.0 - dz / n) / 2.0 * self.rows))
        if dx * dx + dy * dy < 1e-4 * n * n:
            return row, self.cols // 2      # on the axis (within 0.6 degrees): no longitude, the middle
        col = int((math.degrees(math.atan2(dy, dx)) + 180.0) / 360.0 * self.cols) % self.cols
        return row, col

    def column_of_longitude(self, degrees):
        return int((degrees + 180.0) / 360.0 * self.cols) % self.cols


class Gap:
    """A connected set of empty cells: their indices, the unit vector to their middle, their share of the sphere."""

    def __init__(self, cells, centre, fraction):
        self.cells = cells
        self.centre = centre
        self.fraction = fraction


def neighbours(edge):
    """{cell: [cells sharing a side with it]}: centres at most 1.2 cell widths apart.

    Along a face's centre line the cells are 90/n degrees wide; off it and across
    a face's edge their centres are closer, while diagonal neighbours are 1.3x
    or more apart, so 1.2 widths keeps the sides and leaves the corners out."""
    centres = cell_centres(edge)
    limit = math.cos(math.radians(1.2 * 90.0 / edge))
    out = {}
    for a, u in enumerate(centres):
        out[a] = [b for b, v in enumerate(centres) if b != a and u[0] * v[0] + u[1] * v[1] + u[2] * v[2] >= limit]
    return out


def largest_gap(counts, edge):
    """The largest connected region of empty cells (counts: shared/coverage.py's), or None if none is empty."""
    near = neighbours(edge)
    centres = cell_centres(edge)
    seen = set()
    best = None
    for start in range(len(counts)):
        if counts[start] or start in seen:
            continue
        region = [start]
        seen.add(start)
        k = 0
        while k < len(region):
            for b in near[region[k]]:
                if not counts[b] and b not in seen:
                    seen.add(b)
                    region.append(b)
            k += 1
        if best is None or len(region) > len(best):
            best = region
    if best is None:
        return None
    s = [sum(centres[c][i] for c in best) for i in range(3)]
    n = math.sqrt(sum(v * v for v in s))
    if n < 1e-6 * len(best):
        centre = None     # the whole sphere (or a band round it): no one middle
    else:
        centre = tuple(v / n for v in s)
    return Gap(sorted(best), centre, len(best) / float(len(counts)))


def axis_name(i, sign):
    return ("+" if sign >= 0 else "-") + AXES[i]


def describe(d):
    """A direction in the sensor's axes in words: its nearest axis, and the next one when it leans
    that way: "-Z" or "-Z, towards +X"."""
    order = sorted(range(3), key=lambda i: -abs(d[i]))
    first, second = order[0], order[1]
    name = axis_name(first, d[first])
    if abs(d[second]) >= TILT * abs(d[first]):
        name += ", towards " + axis_name(second, d[second])
    return name
