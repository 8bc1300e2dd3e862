"""One push button: debounced short and long presses, polled from the main loop.

    btn = Button(board)
    ev = btn.poll()   # None, SHORT (on release) or LONG (once, while still held)
    btn.pressed_at    # ticks_ms the last press's contact closed (before the debounce): a survey mark's time

Polled rather than interrupt driven: CircuitPython has no user interrupts, and
a human press lasts tens of milliseconds, far longer than a main-loop pass.
Timings are class attributes so a board file can override them (after
peterhinch's Pushbutton).
"""

SHORT = 1
LONG = 2


class Button:
    debounce_ms = 30   # contact bounce of a tactile switch settles within ~10 ms
    long_ms = 1500     # held this long = cancel; fires while held, not on release

    def __init__(self, board):
        self.board = board
        self._level = False      # debounced state
        self._raw = False
        self._changed = board.ticks_ms()
        self._down_at = 0
        self.pressed_at = 0
        self._long_sent = False

    def poll(self):
        b = self.board
        now = b.ticks_ms()
        raw = b.button()
        if raw != self._raw:
            self._raw = raw
            self._changed = now
            return None
        if raw == self._level or b.ticks_diff(now, self._changed) < self.debounce_ms:
            if self._level and not self._long_sent and b.ticks_diff(now, self._down_at) >= self.long_ms:
                self._long_sent = True
                return LONG
            return None
        self._level = raw
        if raw:
            self._down_at = now
            self.pressed_at = self._changed     # the first edge of the level that held
            self._long_sent = False
            return None
        return None if self._long_sent else SHORT
