# Stand-in for CircuitPython's `keypad.Keys`, from docs.circuitpython.org shared-bindings/keypad:
# Keys(pins, *, value_when_pressed, pull=True, interval=0.02, max_events=64,
# debounce_threshold=1) scans in the background and queues Events (key_number, pressed,
# released, timestamp); events.get() returns the next one or None. Here the scan happens
# when the queue is read, against the button's level at the world's current time. Not a
# module of the desktop package.
import microcontroller
import simboard

_board = simboard.board()


class Event:
    def __init__(self, key_number=0, pressed=True, timestamp=None):
        self.key_number = key_number
        self.pressed = pressed
        self.released = not pressed
        self.timestamp = timestamp

    def __repr__(self):
        return "<Event: key_number %d %s>" % (self.key_number, "pressed" if self.pressed else "released")


class EventQueue:
    def __init__(self, keys, max_events):
        self._keys = keys
        self._queue = []
        self._max = max_events
        self.overflowed = False

    def _put(self, event):
        if len(self._queue) >= self._max:
            self.overflowed = True
        else:
            self._queue.append(event)

    def get(self):
        self._keys._scan()
        return self._queue.pop(0) if self._queue else None

    def get_into(self, event):
        e = self.get()
        if e is None:
            return False
        event.key_number, event.pressed, event.released, event.timestamp = e.key_number, e.pressed, e.released, e.timestamp
        return True

    def clear(self):
        self._queue = []
        self.overflowed = False

    def __len__(self):
        self._keys._scan()
        return len(self._queue)

    def __bool__(self):
        return len(self) > 0


class Keys:
    def __init__(self, pins, *, value_when_pressed, pull=True, interval=0.02, max_events=64, debounce_threshold=1):
        if not isinstance(value_when_pressed, bool):
            raise TypeError("value_when_pressed must be a bool")
        self._pins = list(pins)
        for p in self._pins:
            microcontroller.claim(p, "pins")
        self._active = value_when_pressed
        self.key_count = len(self._pins)
        self._pressed = [False] * self.key_count
        self.events = EventQueue(self, max_events)

    def _scan(self):
        for k, p in enumerate(self._pins):
            level = _board.read(p._gpio)
            now = level == (1 if self._active else 0)
            if now != self._pressed[k]:
                self._pressed[k] = now
                self.events._put(Event(k, now, (_board.now_us // 1000) & ((1 << 29) - 1)))

    def reset(self):
        self._pressed = [False] * self.key_count

    def deinit(self):
        for p in self._pins:
            microcontroller.release(p)
        self._pins = []
