"""What `fluxcal calibrate` shows and hears: a live board (rich) or plain lines, and the keys.

Not a command (COMMANDS does not list it).
"""

import os
import select
import sys
import time

# at import, before a session starts: a finish key read at once then comes within a few samples
from desktop.views.coverage_text import TurnWatch, guidance


class _Guide:
    """What both views tell the operator besides the figures: the turning watch and the largest gap."""

    def __init__(self, cfg):
        self.cfg = cfg
        self.start = time.monotonic()
        self.watch = TurnWatch()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def observe(self, ev, coverage):
        """(seconds since the start, the not-turning warning or None, the gap's line or None)."""
        t = time.monotonic() - self.start
        self.watch.add(t, ev.get("dir"), ev.get("coverage") or 0.0)
        gap = guidance(coverage["counts"], coverage["cells_per_edge"]) if coverage else None
        return t, None if ev.get("ready") else self.watch.warning(), gap


class Lines(_Guide):
    """Not a terminal: one line per progress event; the largest gap when the region it names
    changes (else every SAY_EVERY events), a warning when the sensor is not turning (again
    every WARN_EVERY events while it lasts)."""

    wants_map = True
    WARN_EVERY = 5
    SAY_EVERY = 10

    def __init__(self, cfg, auto=True):
        super().__init__(cfg)
        self.said_gap = None
        self.since_said = 0
        self.warned = 0
        self.say_ready = not auto     # the keys' line once, when it first reads READY (the terminal's says it too)

    def update(self, ev, coverage):
        t, warning, gap = self.observe(ev, coverage)
        print("%6.1f s  %s" % (t, progress_line(ev, self.cfg)), flush=True)
        if ev.get("ready") and self.say_ready:
            self.say_ready = False
            print("         READY: f or Enter on standard input finishes (or keep turning; c cancels)", flush=True)
        self.since_said += 1
        where = gap and gap.split(" around ")[-1]      # the region, without its share
        if gap and (where != self.said_gap or self.since_said >= self.SAY_EVERY):
            self.said_gap = where
            self.since_said = 0
            print("         %s" % gap, flush=True)
        if warning:
            if self.warned % self.WARN_EVERY == 0:
                print("         %s" % warning, flush=True)
            self.warned += 1
        else:
            self.warned = 0


def progress_line(ev, cfg, sep="  "):
    pred = "--" if ev.get("pred_nt") is None else "%.3f" % ev["pred_nt"]
    return "coverage %3.0f %% (needs %.0f %%)  samples %5d%spredicted full-sphere error %s nT (needs <= %g nT)%s" % (
        100 * (ev.get("coverage") or 0), 100 * cfg["min_coverage"], ev.get("n", 0), sep, pred,
        cfg["target_error_nt"], "  READY" if ev.get("ready") else "")


class Board(_Guide):
    """A terminal: progress bar, figures and the coverage map, redrawn in place (rich).

    The map's glyphs tell its cells apart without colour (NO_COLOR, which rich honours)."""

    wants_map = True

    def __init__(self, cfg, auto):
        from rich.console import Console
        from rich.live import Live

        super().__init__(cfg)
        self.auto = auto
        self.live = Live(console=Console(), refresh_per_second=4)

    def __enter__(self):
        self.live.__enter__()
        return self

    def __exit__(self, *exc):
        return self.live.__exit__(*exc)

    def update(self, ev, coverage):
        from rich.console import Group
        from rich.progress_bar import ProgressBar
        from rich.table import Table
        from rich.text import Text

        _t, warning, gap = self.observe(ev, coverage)
        cfg = self.cfg
        cov = ev.get("coverage") or 0.0
        bar = Table.grid(padding=(0, 1))
        bar.add_row(ProgressBar(total=1.0, completed=min(1.0, cov / cfg["min_coverage"]), width=50),
                    Text("READY" if ev.get("ready") else "collecting", style="bold green" if ev.get("ready") else ""))
        parts = [Text("Turn the handheld slowly about every axis.", style="bold"), bar,
                 Text(progress_line(ev, cfg, sep="\n")),
                 Text("refused: turning too fast %d, disturbance %d, cell full %d; removed %d" % (
                     ev.get("rej_rate", 0), ev.get("rej_dist", 0), ev.get("rej_cap", 0), ev.get("removed", 0)),
                     style="dim")]
        if warning:
            parts.append(Text(warning, style="bold red"))
        if coverage:
            parts.append(coverage_map(coverage["counts"], coverage["cells_per_edge"], cfg["cell_cap"], ev.get("dir")))
        if gap:
            parts.append(Text(gap, style="bold"))
        if self.auto:
            parts.append(Text("waiting for the firmware to finish by itself", style="italic"))
        elif ev.get("ready"):
            parts.append(Text("READY: press f or Enter to finish (or keep turning to fill the gap; c / Esc cancels)",
                              style="bold green"))
        else:
            parts.append(Text("f / Enter: finish    c / Esc: cancel", style="italic"))
        self.live.update(Group(*parts))


def coverage_map(counts, edge, cap, now=None):
    """The equal-area map (desktop/views/coverage_text.py): its glyphs, each coloured, and the legend."""
    from rich.text import Text

    from desktop.views.coverage_text import STYLES, axis_labels, legend, map_rows, row_label

    grid = map_rows(counts, edge, cap, now)
    text = Text()
    text.append(axis_labels() + "\n", style="bold")
    for r, row in enumerate(grid):
        text.append(row_label(r, len(grid)), style="bold")
        for glyph in row:
            text.append(glyph, style=STYLES[glyph])
        text.append("\n")
    for line in legend(cap):
        text.append(line + "\n", style="dim")
    return text


class Keys:
    """finish / cancel from the keyboard: single keys on a terminal, lines from a pipe.

    f or Enter finishes; c, q or Esc cancels. Disabled (--auto), or at the end
    of a pipe, read() says nothing. `pending` is an action queued by the caller.
    """

    def __init__(self, enabled):
        self.pending = None
        self.fd = None
        self._saved = None
        if enabled and sys.stdin is not None and not sys.stdin.closed:
            self.fd = sys.stdin.fileno()

    def __enter__(self):
        if self.fd is not None and os.isatty(self.fd) and os.name != "nt":
            import termios
            import tty

            self._saved = termios.tcgetattr(self.fd)
            tty.setcbreak(self.fd)
        return self

    def __exit__(self, *exc):
        if self._saved is not None:
            import termios

            termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)
        return False

    def read(self):
        action, self.pending = self.pending, None
        if action or self.fd is None:
            return action
        data = self._windows_key() if os.name == "nt" else self._posix_keys()
        if data is None:
            return None
        data = data.lower()
        if not data:
            self.fd = None      # end of the pipe: no more keys
            return None
        if any(c in data for c in (b"c", b"q", b"\x1b")):
            return "cancel"
        if b"f" in data or b"\n" in data or b"\r" in data:
            return "finish"
        return None

    def _posix_keys(self):
        if not select.select([self.fd], [], [], 0)[0]:
            return None
        return os.read(self.fd, 64)

    @staticmethod
    def _windows_key():
        import msvcrt   # Windows consoles: select() does not take stdin there

        return msvcrt.getwch().encode("ascii", "replace") if msvcrt.kbhit() else None
