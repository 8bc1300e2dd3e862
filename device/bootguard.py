"""A crash loop cannot brick the instrument: boots that never reach a healthy main loop are counted,
and a main loop that keeps failing stops applying the calibration (safe mode).

    starts, crash = bootguard.begin(root)   # at boot, before the calibration is loaded
    bootguard.healthy(root)                 # the main loop ran HEALTHY_MS without an escaping error
    bootguard.crashed(root, "TypeError: ...")   # app.start: an exception escaped the app

    guard = Guard(board, proto)   # app.py: begin() at boot, safe_mode its verdict
    guard.passed()                # a main-loop pass ran through
    guard.finished()              # the loop handed the line to the REPL as asked (`repl`)
    guard.loop_error(e)           # an exception escaped a pass: counted, said, survived
    guard.leave()                 # the operator chose a calibration: safe mode has done its job

boot.txt holds the boots since the last healthy one and the last crash's text.
The app comes up in safe mode (the stored calibration not applied, the protocol
alive, the reason in `status`) when the previous boot recorded a crash or when
SAFE_AFTER boots in a row never became healthy (a hard fault or a watchdog reset
leaves no text): so `clear-cal`, `set-cal` or a redeploy can always reach it.
A reset by the watchdog's timeout (a hung main loop, hal.py) always counts its
boot as unfinished, even one that had become healthy.
A quick power-off within HEALTHY_MS counts as an unfinished boot too; two in a row
are needed before that alone means safe mode.
On a filesystem the firmware cannot write (CircuitPython with the USB drive
writable by the host, boot.py) the guard cannot count and stays out of the way.

Nothing stops the main loop (docs/reliability.md): an exception in a pass is
counted, reported (status, an `error` event at most once a second) and the loop
goes on; a calibration session it interrupts ends with reason internal_error.
SAFE_AFTER_ERRORS passes in a row failing with a calibration applied drop it
(safe mode, a `safe_mode` event): defence in depth, validation should make it
unreachable.
"""

import gc
import os

from store import file_path

from shared import codes

NAME = "boot.txt"
SAFE_AFTER = 2         # unfinished boots before this one
HEALTHY_MS = 5000      # main loop time without an escaping error that counts as a good boot
_TEXT_MAX = 200
_ERROR_EVENT_MS = 1000   # at most one `error` event a second (all are counted)
SAFE_AFTER_ERRORS = 50   # passes in a row failing with a calibration applied: drop it (safe mode)


def _read(root):
    try:
        with open(file_path(root, NAME)) as f:
            text = f.read(400)
    except OSError:
        return 0, None
    lines = text.split("\n")
    try:
        starts = int(lines[0])
    except ValueError:
        return 0, None   # a torn write: no evidence of a crash loop
    crash = lines[1] if len(lines) > 1 and lines[1] else None
    return starts, crash


def _write(root, starts, crash):
    try:
        with open(file_path(root, NAME), "w") as f:
            f.write("%d\n%s\n" % (starts, (crash or "")[:_TEXT_MAX].replace("\n", " ")))
        return True
    except OSError:
        return False


def begin(root, watchdog=False):
    """(unfinished boots before this one, the last crash's text or None); counts this boot.

    watchdog: this boot follows a reset by the watchdog's timeout. The boot it ended hung,
    so it never finished, even when it had become healthy before and cleared the count.
    (On rp2 the reset's reason outlives a soft reset: a main.py run again from the REPL
    after a watchdog reset counts that boot once more.)"""
    starts, crash = _read(root)
    if watchdog and starts < 1:
        starts = 1
    _write(root, starts + 1, crash)
    return starts, crash


def safe_reason(starts, crash):
    """Why this boot must not apply the stored calibration, or None."""
    if crash:
        return "the last boot crashed: %s" % crash
    if starts >= SAFE_AFTER:
        return "%d boots in a row stopped within %d s or hung (crash, watchdog or power)" % (
            starts, HEALTHY_MS // 1000)
    return None


def healthy(root):
    try:
        os.remove(file_path(root, NAME))
    except OSError:
        pass


def crashed(root, text):
    starts, _ = _read(root)
    _write(root, starts, text)


class Guard:
    """The boot's verdict and the main loop's errors. flow (the calibration in force, a
    session to end) is wired by app.py."""

    def __init__(self, board, proto):
        self.board = board
        self.proto = proto
        self.boot_ms = board.ticks_ms()
        self.watchdog_reset = board.reset_by_watchdog()
        starts, crash = begin(board.root, self.watchdog_reset)
        self.unfinished_boots = starts
        self.safe_mode = safe_reason(starts, crash)   # why the calibration is not applied, or None
        self.errors = 0            # exceptions caught in the main loop since boot
        self.last_error = None
        self.flow = None
        self._in_row = 0
        self._error_event_ms = None
        self._healthy = False

    def uptime_ms(self):
        b = self.board
        return b.ticks_diff(b.ticks_ms(), self.boot_ms)

    def passed(self):
        """A pass ran through: the failures in a row end; HEALTHY_MS of them make a good boot."""
        self._in_row = 0
        if not self._healthy and self.uptime_ms() >= HEALTHY_MS:
            self._healthy = True
            healthy(self.board.root)

    def loop_error(self, e):
        """An exception escaped a pass: count it, say it, cancel what it interrupted, go on."""
        self.errors += 1
        self._in_row += 1
        self.last_error = "%s: %s" % (e.__class__.__name__, e)
        if isinstance(e, MemoryError):
            gc.collect()
        b = self.board
        now = b.ticks_ms()
        if self._error_event_ms is None or b.ticks_diff(now, self._error_event_ms) >= _ERROR_EVENT_MS:
            self._error_event_ms = now
            self.proto.event("error", {"where": "main_loop", "error": self.last_error[:200], "count": self.errors})
        flow = self.flow
        flow.abort(codes.INTERNAL_ERROR, self.last_error[:200])
        if self._in_row >= SAFE_AFTER_ERRORS and flow.cal is not None:
            self.safe_mode = "the main loop failed %d times in a row with the calibration applied: %s" % (
                self._in_row, self.last_error[:120])
            flow.drop_calibration()
            self.proto.event("safe_mode", {"reason": self.safe_mode})

    def finished(self):
        """The main loop handed the line to the REPL as asked (`repl`, a deploy): this boot ended
        well, however short, so a few quick redeploys never add up to safe mode."""
        self._healthy = True
        healthy(self.board.root)

    def leave(self):
        """The operator chose a calibration (set-cal, clear-cal, a new one): safe mode has done its job."""
        if self.safe_mode:
            self.safe_mode = None
            healthy(self.board.root)

    def status(self):
        """Its part of `status`."""
        return {"safe_mode": self.safe_mode, "errors": self.errors, "last_error": self.last_error,
                "uptime_ms": self.uptime_ms(), "unfinished_boots": self.unfinished_boots,
                "watchdog_reset": self.watchdog_reset}
