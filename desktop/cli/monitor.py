"""fluxcal monitor [--raw] [--plot [FILE.png]] [--seconds S]: live |B| from the handheld with rolling statistics.

Corrected (default): the firmware's `data` stream, |B| the mean of |h_c| over
each output block (rotation invariant). --raw: the `raw` stream, |B| of the
mean codes times the front-end scale (uncalibrated: it swings as the sensor
turns). Peak-to-peak and standard deviation over the last --window seconds;
the whole run's figures when it ends (--seconds, Ctrl-C, or the plot closed).
"""

import collections
import math
import os
import sys
import time

from desktop.cli._errors import CommandError
from desktop.cli._device import (add_port_arguments, connected, device_config, nT_per_code, quietly,
                                 stream_events)
from shared import codes

HELP = "live |B| from the handheld: rolling peak-to-peak and standard deviation (--plot: a live plot)"


def add_arguments(p):
    p.add_argument("--raw", action="store_true", help="uncorrected readings (the raw stream)")
    p.add_argument("--plot", nargs="?", const=True, default=None, metavar="FILE.png",
                   help="a live plot: |B| over time, the raw point cloud and the coverage of the sphere, in a"
                        " window, or (FILE.png) rewritten into that file every few seconds and at the end")
    p.add_argument("--seconds", type=float, default=None, metavar="S", help="stop after S seconds (default: Ctrl-C)")
    p.add_argument("--window", type=float, default=10.0, metavar="S",
                   help="rolling window of the statistics, seconds (default 10)")
    add_port_arguments(p)


class Rolling:
    """|B| over the last `window` seconds and over the whole run: mean, peak-to-peak, std (nT)."""

    def __init__(self, window):
        self.window = window
        self.recent = collections.deque()     # (t, value)
        self.n = 0
        self.total = self.total2 = 0.0
        self.low = math.inf
        self.high = -math.inf

    def add(self, t, value):
        self.recent.append((t, value))
        while self.recent[0][0] < t - self.window:
            self.recent.popleft()
        self.n += 1
        self.total += value
        self.total2 += value * value
        self.low = min(self.low, value)
        self.high = max(self.high, value)

    def window_figures(self):
        v = [x for _, x in self.recent]
        mean = sum(v) / len(v)
        return mean, max(v) - min(v), math.sqrt(sum((x - mean) ** 2 for x in v) / len(v))

    def run_figures(self):
        mean = self.total / self.n
        return mean, self.high - self.low, math.sqrt(max(0.0, self.total2 / self.n - mean * mean))


def run(args):
    if args.seconds is not None and not args.seconds > 0:
        raise CommandError("--seconds must be positive")
    if not args.window > 0:
        raise CommandError("--window must be positive")
    folder = os.path.dirname(os.path.abspath(args.plot)) if isinstance(args.plot, str) else None
    if folder is not None and not os.path.isdir(folder):
        raise CommandError("--plot %s: there is no folder %s" % (args.plot, folder))
    name = codes.EV_RAW if args.raw else codes.EV_DATA
    with connected(args) as dev:
        cfg = device_config(dev)
        scale = nT_per_code(cfg)
        stream_before = dev.ask("status")["stream"]
        plot = None
        if args.plot:
            from desktop.cli._live_plot import LivePlot, NoDisplay
            try:
                plot = LivePlot(cfg["cells"], scale, "raw" if args.raw else "corrected",
                                path=None if args.plot is True else args.plot, cap=cfg.get("cell_cap"))
            except NoDisplay as exc:
                raise CommandError("monitor --plot: %s; write the plot into a file instead: --plot FILE.png"
                                   % exc) from None
        stats = Rolling(args.window)
        view = _TerminalView(args.window) if sys.stdout.isatty() else _Lines(args.window)
        dev.ask("stream raw" if args.raw else "stream corrected")
        start = time.monotonic()
        try:
            with view:
                for ev in stream_events(dev, name, args.seconds, max(3.0, 5.0 / cfg["survey_hz"])):
                    value = _magnitude(ev, scale) if args.raw else ev["f"]
                    if value is None:
                        continue
                    t = time.monotonic() - start
                    stats.add(t, value)
                    view.update(t, value, stats, ev)
                    if plot is not None and not plot.update(t, value, ev):
                        break   # the window was closed
        except KeyboardInterrupt:
            pass
        finally:
            quietly(dev, "stream %s" % stream_before)
            if plot is not None:
                plot.finish()
    if not stats.n:
        raise CommandError("no %s from the device" % name)
    mean, ptp, std = stats.run_figures()
    print("%d samples over %.1f s, %s |B|: mean %.3f nT, peak-to-peak %.3f nT, std %.3f nT"
          % (stats.n, time.monotonic() - start, "raw" if args.raw else "corrected", mean, ptp, std))
    return 0


def _magnitude(ev, scale):
    c = ev.get("c")
    if not c or None in c:
        return None
    return math.sqrt(sum((ci * k) ** 2 for ci, k in zip(c, scale)))


class _Lines:
    """Not a terminal: one line a second."""

    def __init__(self, window):
        self.window = window
        self.next = 1.0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, t, value, stats, ev):
        if t < self.next:
            return
        self.next = t + 1.0
        mean, ptp, std = stats.window_figures()
        print("%6.1f s  |B| %.3f nT  last %g s: mean %.3f, ptp %.3f, std %.3f nT  %s" % (
            t, value, _span(t, self.window), mean, ptp, std, _notes(ev)), flush=True)


def _span(t, window):
    """The seconds the rolling figures cover: the window, or what has run of it so far."""
    return window if t >= window else round(t, 1)


class _TerminalView:
    """A terminal: a table redrawn in place (rich)."""

    def __init__(self, window):
        from rich.live import Live

        self.window = window
        self.live = Live(refresh_per_second=8, transient=False)

    def __enter__(self):
        self.live.__enter__()
        return self

    def __exit__(self, *exc):
        return self.live.__exit__(*exc)

    def update(self, t, value, stats, ev):
        from rich.table import Table

        mean, ptp, std = stats.window_figures()
        table = Table(title="fluxcal monitor (Ctrl-C stops)", show_header=False, min_width=48)
        table.add_row("|B|", "[bold]%.3f nT[/bold]" % value)
        table.add_row("last %g s" % _span(t, self.window), "mean %.3f nT" % mean)
        table.add_row("", "peak-to-peak [bold]%.3f nT[/bold]" % ptp)
        table.add_row("", "std %.3f nT  (%d samples)" % (std, len(stats.recent)))
        table.add_row("time", "%.1f s" % t)
        table.add_row("", _notes(ev))
        self.live.update(table)


def _notes(ev):
    notes = []
    if ev.get("temp") is not None:
        notes.append("%.2f C" % ev["temp"])
    if ev.get("cal") is False:
        notes.append("UNCALIBRATED")
    if ev.get("warn"):
        notes.append(ev["warn"])
    return "  ".join(notes)
