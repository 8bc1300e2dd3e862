"""What `fluxcal map` writes: map.png and anomalies.csv (the grid: desktop.survey.gridding.write_xyz)."""

import csv

import numpy as np

ANOMALY_COLUMNS = ("number", "kind", "north_m", "east_m", "peak_nT", "peak_north_m", "peak_east_m",
                   "depth_halfwidth_m", "depth_fit_m", "fit_rms_nT", "strike_deg")


def write_anomalies(path, anomalies):
    """anomalies.csv: one row per anomaly, positions in m from the grid's south-west corner."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(ANOMALY_COLUMNS)
        for k, a in enumerate(anomalies, 1):
            w.writerow([k, a.kind, "%.3f" % a.north_m, "%.3f" % a.east_m, "%.2f" % a.peak_nT,
                        "%.3f" % a.peak_north_m, "%.3f" % a.peak_east_m, "%.2f" % a.depth_halfwidth_m,
                        "%.2f" % a.depth_fit_m, "%.2f" % a.fit_rms_nT,
                        "" if a.azimuth_deg is None else "%.0f" % a.azimuth_deg])


def _scale_bar_m(width_m):
    for step in (20.0, 10.0, 5.0, 2.0, 1.0, 0.5):
        if step <= width_m / 4:
            return step
    return 0.5


def write_map(path, grid, clip_nT, title, anomalies=()):
    """Greyscale map (white positive, black negative, clipped at +-clip_nT), north up,
    a scale bar, a north arrow, the grid's origin marked; anomalies numbered."""
    import matplotlib
    matplotlib.use("Agg")       # a file, never a window
    import matplotlib.pyplot as plt

    width = grid.east_m[-1] - grid.east_m[0]
    height = grid.north_m[-1] - grid.north_m[0]
    fig, ax = plt.subplots(figsize=(7.0, 7.0 * max(height, 1) / max(width, 1) * 0.9 + 1.0))
    de, dn = grid.cell_m()[1] / 2, grid.cell_m()[0] / 2
    extent = (grid.east_m[0] - de, grid.east_m[-1] + de, grid.north_m[0] - dn, grid.north_m[-1] + dn)
    im = ax.imshow(np.clip(grid.values, -clip_nT, clip_nT), origin="lower", cmap="gray", extent=extent,
                   vmin=-clip_nT, vmax=clip_nT, interpolation="nearest")
    cb = fig.colorbar(im, ax=ax, fraction=0.04)
    cb.set_label("nT (clipped at +-%g)" % clip_nT)
    ax.set_xlabel("east of origin, m")
    ax.set_ylabel("north of origin, m")
    ax.set_aspect("equal")
    ax.plot([0], [0], "r+", ms=12, mew=2, clip_on=False)
    ax.annotate("origin (0, 0)", (0, 0), xytext=(4, 4), textcoords="offset points", color="red", fontsize=8)
    bar = _scale_bar_m(width)
    x0, y0 = extent[0] + 0.05 * width, extent[2] + 0.05 * max(height, 1)
    ax.plot([x0, x0 + bar], [y0, y0], color="orange", lw=4)
    ax.text(x0 + bar / 2, y0 + 0.02 * max(height, 1), "%g m" % bar, color="orange", ha="center", fontsize=9)
    ax.annotate("N", xy=(0.93, 0.95), xytext=(0.93, 0.83), xycoords="axes fraction", color="orange",
                ha="center", fontsize=12, arrowprops=dict(arrowstyle="-|>", color="orange", lw=2))
    for k, a in enumerate(anomalies, 1):
        ax.plot(a.east_m, a.north_m, "o", mfc="none", mec="red", ms=10)
        ax.annotate(str(k), (a.east_m, a.north_m), xytext=(6, 6), textcoords="offset points", color="red",
                    fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
