"""The plots of `fluxcal report` (matplotlib, written as PNG). Not a command.

    write_figures(folder, h, corrected, t, cal, counts, edge) -> [(file name, title)]

h, corrected: (N, 3) raw and corrected readings, nT; t: (N,) s or None (samples numbered); cal: a
Calibration taking nT; counts: shared/coverage.py's cell counts. The sphere's maps and the rate
plot are desktop/views/figures.py's.
"""

import os

import numpy as np

MAX_POINTS = 4000     # points drawn in the 3-D views (every sample goes into the numbers)


def write_figures(folder, h, corrected, t, cal, counts, edge):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from desktop.views.figures import coverage_figure, error_figure, rate_figure
    from desktop.views.verdict import CELL_CAP

    out = []
    for name, title, draw in (
            ("coverage.png", "Coverage of the sphere", lambda: coverage_figure(plt, counts, edge, CELL_CAP)),
            ("error_map.png", "Error on the sphere: |h_c| - field by direction",
             lambda: error_figure(plt, corrected, cal.field)),
            ("rate.png", "Residual against rotation rate",
             lambda: rate_figure(plt, corrected, cal.field, np.arange(len(h), dtype=float) if t is None else t,
                                 t is not None)),
            ("ellipsoid.png", "Raw ellipsoid and corrected sphere",
             lambda: _shapes(plt, h, corrected, t, cal, counts, edge)),
            ("magnitude.png", "|B| before and after", lambda: _magnitude(plt, h, corrected, t, cal, counts, edge)),
            ("residuals.png", "Residuals |h_c| - field",
             lambda: _residuals(plt, h, corrected, t, cal, counts, edge))):
        fig = draw()
        fig.savefig(os.path.join(folder, name), dpi=100)
        plt.close(fig)
        out.append((name, title))
    return out


def _surface(centre, shape, n=24):
    """Wireframe of centre + shape @ u over unit vectors u: (3, n, n) arrays."""
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n), np.linspace(0, np.pi, n))
    sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])
    return np.einsum("ij,jkl->ikl", shape, sphere) + np.asarray(centre)[:, None, None]


def _shapes(plt, h, corrected, t, cal, counts, edge):
    step = max(1, len(h) // MAX_POINTS)
    fig = plt.figure(figsize=(11, 5))
    m = np.asarray(cal.matrix)
    for k, (pts, surf, title) in enumerate((
            (h, _surface(cal.offset, cal.field * np.linalg.inv(m)), "raw readings: an ellipsoid"),
            (corrected, _surface(np.zeros(3), cal.field * np.eye(3)), "corrected: a sphere of |B| = %.1f nT" % cal.field))):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        ax.plot_wireframe(*surf, color="lightgrey", lw=0.5)
        shown = pts[::step]
        # the distortion is ~1 % of the radius: invisible in the shape, plain in the colour
        off = np.linalg.norm(shown, axis=1) - cal.field
        dots = ax.scatter(*shown.T, s=2, c=off, cmap="coolwarm")
        fig.colorbar(dots, ax=ax, shrink=0.6, label="|h| - field (nT)")
        ax.set_box_aspect((1, 1, 1))
        ax.set_title(title)
        ax.set_xlabel("x (nT)")
        ax.set_ylabel("y (nT)")
        ax.set_zlabel("z (nT)")
    return fig


def _magnitude(plt, h, corrected, t, cal, counts, edge):
    fig, (a, b) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    raw = np.linalg.norm(h, axis=1)
    mag = np.linalg.norm(corrected, axis=1)
    x = np.arange(len(h)) if t is None else t     # None: a log without a time column
    a.plot(x, raw, lw=0.6, color="tab:red")
    a.set_ylabel("raw |B| (nT)")
    a.set_title("before: peak-to-peak %.1f nT" % np.ptp(raw))
    b.plot(x, mag, lw=0.6, color="tab:blue")
    b.set_ylabel("corrected |B| (nT)")
    b.set_title("after: peak-to-peak %.3f nT, std %.3f nT" % (np.ptp(mag), mag.std()))
    b.set_xlabel("sample number (the log has no time column)" if t is None else "time (s)")
    fig.tight_layout()
    return fig


def _residuals(plt, h, corrected, t, cal, counts, edge):
    resid = np.linalg.norm(corrected, axis=1) - cal.field
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.hist(resid, bins=60, color="tab:blue")
    ax.set_xlabel("|h_c| - field (nT)")
    ax.set_ylabel("samples")
    ax.set_title("rms %.3f nT, std %.3f nT, %d samples" % (np.sqrt(np.mean(resid ** 2)), resid.std(), len(resid)))
    fig.tight_layout()
    return fig
