"""Status LED patterns, driven from the main loop by time (no timers needed).

A pattern is a tuple of on/off durations in ms, repeated. One glance tells
the operator the state (docs/firmware.md has the table):
"""

UNCALIBRATED = (100, 1900)            # short blip every 2 s
SURVEY = (1000, 1000)                 # calm 0.5 Hz: calibrated, measuring
COLLECTING = (250, 250)               # 2 Hz: keep rotating
ENOUGH = (60, 90)                     # fast flicker: coverage reached, press to finish
DONE = (2000, 0)                      # solid 2 s: calibration accepted
# three long pulses: quick re-calibration accepted (off before and after, so they never
# merge with the pattern around them)
DONE_QUICK = (0, 300, 600, 200, 600, 200, 600, 400)
SLOW_DOWN = (900, 100)                # mostly on: turning faster than the sensor's bandwidth allows
FAILED = (100, 100, 100, 100, 100, 100, 800, 400)  # triple blink, twice
# one long pulse, then a triple blink: a new calibration predicted worse than the one in force,
# which stays (off first, so the pulse never merges with the pattern before it)
KEPT_PREVIOUS = (0, 300, 1200, 300, 100, 100, 100, 100, 100, 400)
FAULT = (50, 50)                      # ADC fault: not answering, DRDY stuck, bad frames
SAFE = (100, 100, 100, 1700)          # double blip: safe mode, the stored calibration not applied


class Led:
    def __init__(self, board):
        self.board = board
        self.base = UNCALIBRATED
        self._pattern = UNCALIBRATED
        self._until = None      # a one-shot pattern reverts to base at this tick
        self._start = board.ticks_ms()
        self._next = -1         # age (ms since _start) of the next change: nothing to do before it

    def set(self, pattern):
        """Change the steady pattern (a one-shot in progress finishes first)."""
        if pattern is not self.base:
            self.base = pattern
            if self._until is None:
                self._pattern = pattern
                self._start = self.board.ticks_ms()
                self._next = -1

    def flash(self, pattern, ms=None):
        """Show a pattern once (or for ms), then return to the steady one."""
        b = self.board
        self._pattern = pattern
        self._start = b.ticks_ms()
        self._until = (ms if ms is not None else sum(pattern)) or 1
        self._next = -1

    def due_ms(self, most):
        """ms until the next change update() found (at least 1), at most `most`: the pass's sleep (app.py)."""
        b = self.board
        left = self._next - b.ticks_diff(b.ticks_ms(), self._start)
        return most if left > most else (left if left > 1 else 1)

    def update(self):
        # every main-loop pass: return at once until the next change is due. The change is a
        # method of its own so that this frame stays within the 11 words MicroPython keeps off the
        # heap (app.py, Frames): the pass's call allocates nothing
        b = self.board
        now = b.ticks_ms()
        age = b.ticks_diff(now, self._start)
        if age >= self._next:
            self._change(now, age)

    def _change(self, now, age):
        if self._until is not None and age >= self._until:
            self._until = None
            self._pattern = self.base
            self._start = now
            age = 0
        p = self._pattern
        period = sum(p)
        t = age % period if period else 0
        on = True
        left = 0
        for d in p:
            if t < d:
                left = d - t
                break
            t -= d
            on = not on
        nxt = age + left
        if self._until is not None and self._until < nxt:
            nxt = self._until
        self._next = nxt
        self.board.led(on)
