"""Interpolation of traverses onto a regular grid, and the grid as an XYZ/CSV file.

The traverses' samples are already regular along the lines (desktop.survey.traverses
bins them); across the lines the grid is linear between neighbouring traverses at
half the line spacing (Geoplot's linear Interpolate), held flat beyond the outer lines.
"""

import numpy as np


class MapGrid:
    """values (N_north, N_east) nT at north_m (N_north,) x east_m (N_east,) m from the grid's origin."""

    def __init__(self, north_m, east_m, values):
        self.north_m, self.east_m, self.values = north_m, east_m, values

    def cell_m(self):
        return (float(self.north_m[1] - self.north_m[0]) if len(self.north_m) > 1 else 0.0,
                float(self.east_m[1] - self.east_m[0]) if len(self.east_m) > 1 else 0.0)

    def sample(self, north, east):
        """Bilinear value at (north, east) m (arrays), clamped to the grid."""
        fi = np.interp(north, self.north_m, np.arange(len(self.north_m)))
        fj = np.interp(east, self.east_m, np.arange(len(self.east_m)))
        i0 = np.clip(np.floor(fi).astype(int), 0, max(len(self.north_m) - 2, 0))
        j0 = np.clip(np.floor(fj).astype(int), 0, max(len(self.east_m) - 2, 0))
        i1, j1 = np.minimum(i0 + 1, len(self.north_m) - 1), np.minimum(j0 + 1, len(self.east_m) - 1)
        a, b = fi - i0, fj - j0
        v = self.values
        return (v[i0, j0] * (1 - a) * (1 - b) + v[i1, j0] * a * (1 - b) + v[i0, j1] * (1 - a) * b
                + v[i1, j1] * a * b)


def interpolate(lines, grid, interpolate_across=True):
    """A MapGrid from the traverses; without interpolation one column per traverse."""
    north = lines[0].north_m
    ys = np.array([ln.east_m for ln in lines])
    cols = np.stack([ln.nT for ln in lines], axis=1)             # (N_north, L)
    if not interpolate_across or len(lines) < 2:
        return MapGrid(north, ys, cols)
    # nodes on every traverse and halfway between: first line to last, at half the spacing
    east = ys[0] + np.arange(2 * len(ys) - 1) * (0.5 * (ys[-1] - ys[0]) / (len(ys) - 1))
    fj = np.interp(east, ys, np.arange(len(ys)))
    j0 = np.clip(np.floor(fj).astype(int), 0, len(ys) - 2)
    w = (fj - j0)[None, :]
    return MapGrid(north, east, cols[:, j0] * (1 - w) + cols[:, j0 + 1] * w)


def write_xyz(path, grid, what):
    """The grid as CSV: '#' header lines saying what it is, then east_m,north_m,nT rows."""
    de, dn = grid.cell_m()[1], grid.cell_m()[0]
    header = ["fluxcal map grid: %s" % what,
              "origin: the grid's south-west corner; east_m east, north_m north of it; "
              "cells %.3f m (east) x %.3f m (north)" % (de, dn),
              "columns: east_m,north_m,nT (total-field anomaly)"]
    ee, nn = np.meshgrid(grid.east_m, grid.north_m)
    rows = np.c_[ee.ravel(), nn.ravel(), grid.values.ravel()]
    with open(path, "w") as fh:
        for line in header:
            fh.write("# %s\n" % line)
        fh.write("east_m,north_m,nT\n")
        np.savetxt(fh, rows, fmt=("%.3f", "%.3f", "%.3f"), delimiter=",")
