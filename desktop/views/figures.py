"""The sphere's pictures with matplotlib: coverage, the error by direction, the residual against rotation rate.

    draw_coverage(ax, counts, edge, cap, now=None)       # on an Axes: the equal-area map of the cells
    fig = coverage_figure(plt, counts, edge, cap)        # a figure of it, with its legend
    fig = error_figure(plt, corrected, field)            # mean |h_c| - field by direction, nT
    fig = rate_figure(plt, corrected, field, t, timed)   # |h_c| - field against the rotation rate

The map is desktop/views/sphere.py's equal-area projection (longitude about Z
across, z up): the same picture as the terminal's, so a square's share of the
map is its share of the sphere. Coverage is drawn in three grey levels with the
cells' borders, readable in print and without colour; the markers differ in
shape, not only in colour.
"""

import math

import numpy as np

from desktop.methods.turn_rate import ERR_COLS, ERR_ROWS, error_by_direction, lon_z, rate_effect, rate_residuals
from desktop.views.sphere import SphereMap, describe, largest_gap

LONGITUDES = ((-180, "-X"), (-90, "-Y"), (0, "+X"), (90, "+Y"), (180, "-X"))
GREYS = {"empty": "1.0", "some": "0.65", "full": "0.3"}
RES_COLS, RES_ROWS = 360, 120      # the coverage image's pixels: fine enough for the cells' borders


_CELLS = {}


def _cells(edge):
    """The coverage cell under each pixel of the map, (RES_ROWS, RES_COLS); made once per edge."""
    if edge not in _CELLS:
        _CELLS[edge] = np.array(SphereMap(edge, RES_COLS, RES_ROWS).cell)
    return _CELLS[edge]


def _frame(ax):
    ax.set_xlim(-180, 180)
    ax.set_ylim(-1, 1)
    ax.set_xticks([lon for lon, _ in LONGITUDES])
    ax.set_xticklabels([name for _, name in LONGITUDES])
    ax.set_yticks([-1, 0, 1])
    ax.set_yticklabels(["-Z", "z = 0", "+Z"])
    ax.set_xlabel("longitude about Z (equal-area map: every square the same share of the sphere)")


def draw_coverage(ax, counts, edge, cap, now=None):
    """The equal-area map of shared/coverage.py's cells on `ax`: grey by fill, their borders,
    the sensor's direction now (a ring) and the middle of the largest gap (a cross). Returns legend handles."""
    from matplotlib.colors import ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    cells = _cells(edge)                          # row 0 at +Z
    counts = np.asarray(counts)
    cap = max(1, cap or counts.max() or 1)
    level = np.where(counts[cells] == 0, 0, np.where(counts[cells] >= cap, 2, 1))
    cmap = ListedColormap([GREYS["empty"], GREYS["some"], GREYS["full"]])
    ax.imshow(level, cmap=cmap, vmin=0, vmax=2, extent=(-180, 180, -1, 1), aspect="auto",
              interpolation="nearest")
    # the cells' borders: where a pixel's cell differs from its right or lower neighbour, in black
    border = np.zeros(cells.shape, bool)
    border[:, :-1] |= cells[:, 1:] != cells[:, :-1]
    border[:-1, :] |= cells[1:, :] != cells[:-1, :]
    overlay = np.zeros(cells.shape + (4,))
    overlay[border, 3] = 0.9
    overlay[border & (level == 2), :3] = 1.0    # white on full cells, black elsewhere: every cell outlined
    ax.imshow(overlay, extent=(-180, 180, -1, 1), aspect="auto", interpolation="nearest")
    handles = [Patch(facecolor=GREYS["full"], edgecolor="k", label="full (%d samples)" % cap),
               Patch(facecolor=GREYS["some"], edgecolor="k", label="some samples"),
               Patch(facecolor=GREYS["empty"], edgecolor="k", label="empty")]
    gap = largest_gap(list(counts), edge)
    if gap is not None and gap.centre is not None:
        lon, z = lon_z(gap.centre)
        ax.plot(lon, z, marker="X", ms=14, mfc="tab:cyan", mec="k", ls="none")
        handles.append(Line2D([], [], marker="X", ms=10, mfc="tab:cyan", mec="k", ls="none",
                              label="largest gap: %s (%.0f %%)" % (describe(gap.centre), 100 * gap.fraction)))
    if now is not None and any(now):
        lon, z = lon_z(now)
        ax.plot(lon, z, marker="o", ms=14, mfc="none", mec="tab:purple", mew=3, ls="none")
        handles.append(Line2D([], [], marker="o", ms=10, mfc="none", mec="tab:purple", mew=3, ls="none",
                              label="the sensor now"))
    _frame(ax)
    return handles


def coverage_title(counts):
    seen = int(np.count_nonzero(counts))
    return "cells visited: %d of %d (%.0f %%)" % (seen, len(counts), 100.0 * seen / len(counts))


def coverage_figure(plt, counts, edge, cap, now=None, title=None):
    fig, ax = plt.subplots(figsize=(10, 4.2))
    handles = draw_coverage(ax, counts, edge, cap, now)
    ax.set_title(title or "Coverage of the sphere: " + coverage_title(counts))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              title="a square at +Z fills while the\nsensor's +Z axis points along\nthe Earth's field", title_fontsize=8)
    fig.tight_layout()
    return fig


def error_figure(plt, corrected, field):
    grid = error_by_direction(corrected, field)
    fig, ax = plt.subplots(figsize=(10, 4.2))
    top = float(np.nanmax(np.abs(grid))) if np.isfinite(grid).any() else 1.0
    top = top if top > 0 else 1.0
    ax.set_facecolor("0.85")
    im = ax.imshow(np.ma.masked_invalid(grid), cmap="RdBu_r", vmin=-top, vmax=top, extent=(-180, 180, -1, 1),
                   aspect="auto", interpolation="nearest")
    # the numbers too, so the map reads without its colours
    for r in range(ERR_ROWS):
        for c in range(ERR_COLS):
            v = grid[r, c]
            if np.isfinite(v) and c % 2 == 0:
                ax.text(-180 + (c + 0.5) * 360.0 / ERR_COLS, 1 - (r + 0.5) * 2.0 / ERR_ROWS,
                        "%.0f" % v if abs(v) >= 10 else "%.2g" % v,
                        ha="center", va="center", fontsize=5)
    fig.colorbar(im, ax=ax, label="mean |h_c| - field (nT)")
    _frame(ax)
    seen = np.isfinite(grid)
    worst = np.unravel_index(np.nanargmax(np.abs(grid)), grid.shape) if seen.any() else None
    where = ""
    if worst is not None:
        d = SphereMap(1, ERR_COLS, ERR_ROWS).direction(*worst)
        where = "; largest %.3f nT around %s" % (grid[worst], describe(d))
    ax.set_title("Error on the sphere: |h_c| - field by direction (grey: no sample), %.0f %% of the sphere seen%s"
                 % (100.0 * seen.mean(), where), fontsize=9)
    fig.tight_layout()
    return fig


def rate_figure(plt, corrected, field, t, timed):
    rate, r = rate_residuals(corrected, field, t)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    step = max(1, len(rate) // 4000)
    ax.scatter(rate[::step], r[::step], s=2, c="0.5", label="samples (their direction's mean removed)")
    unit = "deg/s" if timed else "deg per sample"
    if len(rate) >= 20:
        edges = np.unique(np.percentile(rate, np.linspace(0, 100, 11)))
        mids, means = [], []
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = (rate >= lo) & (rate <= hi)
            if sel.any():
                mids.append(0.5 * (lo + hi))
                means.append(r[sel].mean())
        ax.plot(mids, means, "k-o", ms=4, label="mean per tenth of the samples")
    effect = rate_effect(corrected, field, t)
    title = "Residual against rotation rate"
    if effect is not None:
        title += ": %+.3f nT (+- %.3f) at %.3g %s" % (effect.slope, effect.se, effect.w90, unit)
    ax.set_title(title)
    ax.set_xlabel("rotation rate (%s)" % unit)
    ax.set_ylabel("|h_c| - field - its direction's mean (nT)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
