"""One push button: debounced short and long presses, polled from the main loop.

    btn = Button(board)
    ev = btn.poll()   # None, SHORT (on release) or LONG (once, while still held)
    btn.pressed_at    # ticks_ms the last press's contact closed (before the debounce): a survey mark's time
    btn.due_ms(40)    # ms until it needs the next poll, at most 40 (app.py's pass)

Polled rather than interrupt driven: CircuitPython has no user interrupts, and
a human press lasts tens of milliseconds, far longer than a main-loop pass. Where the board
times the closing with an interrupt (hal button_edge: MicroPython), the press counts from it:
a pass that finds the contact closed up to app.py's _IDLE_MS after it takes the press at once
if it has held debounce_ms, and pressed_at is the closing itself.
Timings are class attributes so a board file can override them (after
peterhinch's Pushbutton).
"""

SHORT = 1
LONG = 2


class Button:
    debounce_ms = 30   # contact bounce of a tactile switch settles within ~10 ms
    long_ms = 1500     # held this long = cancel; fires while held, not on release
    held_ms = 20       # a poll at least this often while held (due_ms)

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
            self._changed = b.button_edge(now) if raw else now
            if b.ticks_diff(now, self._changed) < self.debounce_ms:
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

    def due_ms(self, most):
        """ms until the next poll is due (at least 1), at most `most`: app.py's pass. Idle, `most`
        (where an interrupt times the closings); held, held_ms (its release, its long press);
        settling, the debounce's end."""
        if self._raw == self._level:
            return most if not self._raw or most < self.held_ms else self.held_ms
        b = self.board
        left = self.debounce_ms - b.ticks_diff(b.ticks_ms(), self._changed)
        return 1 if left < 1 else (left if left < most else most)
