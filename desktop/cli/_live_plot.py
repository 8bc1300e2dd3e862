"""monitor --plot: |B| over time, the raw point cloud, and the sphere's cells visited (matplotlib).

Not a command (COMMANDS does not list it). The cells are shared/coverage.py's,
counted from the directions of the corrected field (raw: of the readings,
whose offset is small beside the Earth's field), on the same equal-area map as
`calibrate` and `report` draw (desktop/views/figures.py), the sensor's
direction now marked and the largest gap named.
"""

import os
import time

REDRAW_S = 0.5
SAVE_S = 2.0        # a file is rewritten less often than a window is redrawn
MAX_POINTS = 4000


# matplotlib's backends that draw into files only: what it falls back on without a display
FILE_BACKENDS = {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"}


class NoDisplay(Exception):
    """A live window was asked for where matplotlib cannot open one."""


class LivePlot:
    """A window redrawn as samples come, or (path) a PNG rewritten as they come and at the end."""

    def __init__(self, cells, scale, kind, path=None, cap=None):
        import matplotlib
        if path is not None:
            matplotlib.use("agg")      # a file needs no display, and must not open a window
        import matplotlib.pyplot as plt
        if path is None and plt.get_backend().lower() in FILE_BACKENDS:
            raise NoDisplay("matplotlib has no display to open a window on (backend %s)" % plt.get_backend())

        from shared.coverage import Coverage

        self.plt = plt
        self.scale = scale
        self.coverage = Coverage(cells)
        self.now = None
        self.cap = cap or 1     # the firmware's cell_cap: a cell drawn full holds what a calibration takes
        self.t, self.b, self.points = [], [], []
        self.next_draw = 0.0
        self.path = path
        if path is None:
            plt.ion()
        self.fig = plt.figure("fluxcal monitor", figsize=(13, 5.5))
        self.fig.subplots_adjust(bottom=0.3, wspace=0.3)     # room for the map's legend below it
        self.ax_b = self.fig.add_subplot(1, 3, 1)
        self.ax_cloud = self.fig.add_subplot(1, 3, 2, projection="3d")
        self.ax_cov = self.fig.add_subplot(1, 3, 3)
        self.kind = kind
        self.closed = False
        self.fig.canvas.mpl_connect("close_event", self._on_close)

    def _on_close(self, _event):
        self.closed = True

    def update(self, t, value, ev):
        """Take a sample; redraw now and then. False once the window is closed."""
        self.t.append(t)
        self.b.append(value)
        c = ev.get("c")
        if c and None not in c:
            p = [ci * k for ci, k in zip(c, self.scale)]
            self.points.append(p)
            d = ev.get("b") or p
            if any(d):
                self.coverage.add_to(self.coverage.cell(*d))
                self.now = d
        now = time.monotonic()
        if now >= self.next_draw:
            self.next_draw = now + (REDRAW_S if self.path is None else SAVE_S)
            self._draw()
            if self.path is None:
                self.plt.pause(0.001)
            else:
                self.save()
        return not self.closed

    def save(self):
        """The figure as it is now into path (through a .tmp: a viewer never reads half a PNG)."""
        tmp = self.path + ".tmp.png"
        self.fig.savefig(tmp, dpi=90)
        os.replace(tmp, self.path)

    def finish(self):
        """The last picture: into the file (a window stays as it is)."""
        if self.path is not None:
            self._draw()
            self.save()

    def _draw(self):
        ax = self.ax_b
        ax.clear()
        ax.plot(self.t, self.b, lw=0.8)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("%s |B| (nT)" % self.kind)
        ax.set_title("|B|")
        pts = self.points[-MAX_POINTS:]
        ax = self.ax_cloud
        ax.clear()
        if pts:
            xs, ys, zs = zip(*pts)
            ax.scatter(xs, ys, zs, s=2, c=range(len(pts)), cmap="viridis")
        ax.set_box_aspect((1, 1, 1))
        ax.set_title("raw readings (nT)")
        ax = self.ax_cov
        ax.clear()
        from desktop.views.figures import coverage_title, draw_coverage

        handles = draw_coverage(ax, self.coverage.counts, self.coverage.edge, self.cap, self.now)
        ax.set_xlabel("longitude about Z (equal-area map)")
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.16), fontsize=7, ncol=2)
        ax.set_title("sphere " + coverage_title(self.coverage.counts), fontsize=9)
