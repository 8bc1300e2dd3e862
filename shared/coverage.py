"""Which orientations have been seen: roughly equal-area cells on the sphere.

    from shared.coverage import Coverage
    cov = Coverage(cells_per_edge=4, cap=40)   # 6 * 4 * 4 = 96 cells
    if cov.add(dx, dy, dz):                     # direction relative to the centre
        fit.add(x, y, z)                        # the cell was not full yet
    cov.fraction()                              # share of cells holding a sample
    i = cov.cell(dx, dy, dz); cov.count(i); cov.add_to(i); cov.remove_from(i)   # by cell index

Cells are the faces of a cube projected onto the sphere, each face cut into
n x n cells at equal *angles* (tan of -45 .. 45 degrees), not equal lengths:
equal-angle cells differ in area by at most 1.2x (exactly 1.199 for n = 4, from the
solid angles of the gnomonic rectangles), against 5x for a plain grid
on the cube face. The cut points are integer ratios (TAN_BITS fixed point), so
a cell is found with integer multiplications and comparisons only; floats
work too. The per-cell cap keeps a few densely visited orientations (a hand
lingers where it is comfortable) from outweighing the rest of the sphere.
"""

import math

try:
    from array import array
except ImportError:  # pragma: no cover - every target runtime has array
    array = None

TAN_BITS = 12
_ONE = 1 << TAN_BITS


class Coverage:
    def __init__(self, cells_per_edge=4, cap=None):
        if not 1 <= cells_per_edge <= 16:
            raise ValueError("cells_per_edge must be 1..16, got %r" % (cells_per_edge,))
        self.edge = cells_per_edge
        self.n_cells = 6 * cells_per_edge * cells_per_edge
        self.cap = cap
        # Interior cut points tan(-45 + 90 k / n degrees), k = 1..n-1, fixed point.
        self._cuts = [int(round(math.tan(math.radians(-45.0 + 90.0 * k / cells_per_edge)) * _ONE))
                      for k in range(1, cells_per_edge)]
        self.counts = array("H", [0] * self.n_cells) if array else [0] * self.n_cells

    def cell(self, dx, dy, dz):
        """Index of the cell holding direction (dx, dy, dz); any scale, any sign.

        Runs once per calibration sample on the device: no calls, no tuples (a
        method call costs ~1k instructions on a Cortex-M, docs/firmware.md)."""
        ax = dx if dx >= 0 else -dx
        ay = dy if dy >= 0 else -dy
        az = dz if dz >= 0 else -dz
        if ax >= ay and ax >= az:
            face = 0 if dx >= 0 else 1
            major = ax
            p = dy
            q = dz
        elif ay >= az:
            face = 2 if dy >= 0 else 3
            major = ay
            p = dx
            q = dz
        else:
            face = 4 if dz >= 0 else 5
            major = az
            p = dx
            q = dy
        if major == 0:
            raise ValueError("zero direction has no cell")
        # p / major and q / major against the cut tangents, without dividing: the bin is
        # the number of cuts at or below the ratio (the cuts ascend)
        p = p * _ONE
        q = q * _ONE
        i = j = 0
        for cut in self._cuts:
            c = cut * major
            if p >= c:
                i += 1
            if q >= c:
                j += 1
        e = self.edge
        return (face * e + i) * e + j

    def count(self, cell):
        """Samples counted in `cell`."""
        return self.counts[cell]

    def add_to(self, cell):
        """Count a sample in `cell`; False (and not counted) if it already holds `cap`."""
        c = self.counts[cell]
        if self.cap is not None and c >= self.cap:
            return False
        if c < 65535:
            self.counts[cell] = c + 1
        return True

    def remove_from(self, cell):
        """Undo add_to for a sample taken back out of the fit (EllipsoidFit.remove)."""
        if self.counts[cell] > 0:
            self.counts[cell] -= 1

    def add(self, dx, dy, dz):
        """Count a sample by its direction; False (and not counted) if its cell is full."""
        return self.add_to(self.cell(dx, dy, dz))

    def remove(self, dx, dy, dz):
        """Undo add() for a sample taken back out of the fit."""
        self.remove_from(self.cell(dx, dy, dz))

    def fraction(self, min_count=1):
        """Share of cells holding at least min_count samples, 0..1."""
        hit = 0
        for c in self.counts:
            if c >= min_count:
                hit += 1
        return hit / self.n_cells

    def reset(self):
        for i in range(self.n_cells):
            self.counts[i] = 0
