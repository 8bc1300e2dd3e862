"""Simulation HAL: the board seen through a link to the desktop's emulated ADS1292.

    Board(link, root, lock_heap_in_isr=False, polled=False, costs=None)

The link is sim_link.PipeLink when the firmware runs in the `micropython`
executable (sim_main.py), or the desktop's World object itself when it runs in
CPython (desktop/devicesim/runners.py). Simulated time advances only on the
host, so runs are deterministic.

Main-loop time. The host cannot see how long the firmware computes, so the
board charges a cost model instead: `costs` maps a `busy` key to simulated
microseconds per unit (desktop/devicesim/costs.py holds the defaults). A
charged stall lets chip time pass. With `polled` False (a hard IRQ,
MicroPython) the DRDY handler still runs for every conversion inside the
stall, as an interrupt would; with `polled` True (CircuitPython) it does not,
and on the next DRDY the board measures the time since the last serviced one
and reports round(elapsed * rate) - 1 unseen conversions to on_gap, as
hal_circuitpython.py does on hardware.
The contract's default hand_back is this HAL's: there is no REPL to give the
line back to, and sim_main.py's process ends with the main loop.
"""

import sys

import hal
from sim_wire import F_BUTTON, F_DRDY, F_QUIT, F_SERIAL, PIN_LED, PIN_RESET, PIN_START, T_MASK

try:
    import micropython
    _heap_lock = micropython.heap_lock
    _heap_unlock = micropython.heap_unlock
except (ImportError, AttributeError):  # CPython
    _heap_lock = _heap_unlock = None

_TICKS_HALF = (T_MASK + 1) // 2


class Board(hal.Board):
    def __init__(self, link, root=".", lock_heap_in_isr=False, polled=False, costs=None):
        self.link = link
        self.root = root
        self.name = "sim-" + sys.implementation.name + ("-polled" if polled else "")
        self.polled = self.polls_drdy = polled
        self.costs = dict(costs or {})   # busy key -> simulated us per unit
        self._handler = None
        self._rate = 0
        self._on_gap = None
        self._last = -1        # t_us of the last serviced DRDY (polled), -1: none yet
        self._led = -1
        self._t_prev = None    # ticks_ms: the link's t_us at the last call, the us left over, the ms clock
        self._us = 0
        self._ms = 0
        # Under MicroPython: run the DRDY handler with the heap locked, which is
        # what a hard IRQ enforces; an allocation there raises MemoryError.
        self._lock = lock_heap_in_isr and _heap_lock is not None
        self.link.idle()

    # bus
    def set_spi_rate(self, hz):
        self.link.set_baud(hz)

    def spi_write(self, chip, buf, n):
        self.link.xfer(chip, buf, None, n)

    def spi_write_readinto(self, chip, wbuf, rbuf, n):
        self.link.xfer(chip, wbuf, rbuf, n)

    def spi_readinto(self, chip, buf):
        self.link.xfer(chip, None, buf, len(buf))

    # pins
    def set_start(self, v):
        self.link.pin(PIN_START, 1 if v else 0)

    def set_reset(self, v):
        self.link.pin(PIN_RESET, 1 if v else 0)

    def led(self, on):
        v = 1 if on else 0
        if v != self._led:
            self._led = v
            self.link.pin(PIN_LED, v)

    def button(self):
        return bool(self.link.flags & F_BUTTON)

    def attach_drdy(self, handler, rate=0, on_gap=None):
        self._handler = handler
        self._rate = rate
        self._on_gap = on_gap
        self._last = -1   # (re)started conversions: no gap to measure yet

    # time: simulated, advanced by the host only
    def ticks_ms(self):
        # The link's clock is in us and wraps at 2**30 us (17.9 min); a ms clock taken from it
        # as (t_us // 1000) would wrap there too, not at 2**30 ms as ticks_diff assumes (a
        # difference across it off by 17.9 min: found by the long run). So the ms clock
        # counts the us that passed since the last call (the main loop calls it 50 times a
        # second, far inside the wrap).
        # The link's t_us may step back a little (the HAL advances it locally in sleep_us, the
        # World's next reply sets its own): the clock holds until it passes its last value.
        t = self.link.t_us
        if self._t_prev is None:   # the first reading: the clock starts where the link's is
            self._t_prev = t
            self._ms = t // 1000
            self._us = t - self._ms * 1000
        d = ((t - self._t_prev + _TICKS_HALF) & T_MASK) - _TICKS_HALF
        if d > 0:
            self._t_prev = t
            us = self._us + d
            ms = us // 1000
            self._us = us - ms * 1000
            self._ms = (self._ms + ms) & T_MASK
        return self._ms

    def ticks_diff(self, a, b):
        return ((a - b + _TICKS_HALF) & T_MASK) - _TICKS_HALF

    def sleep_us(self, us):
        self.link.sleep_us(us)
        self.link.t_us = (self.link.t_us + us) & T_MASK

    def quit_requested(self):
        return bool(self.link.flags & F_QUIT)

    def idle(self):
        link = self.link
        link.idle()
        if link.flags & F_DRDY and self._handler is not None:
            if self.polled:
                self._gap(link.t_us)
            self._isr()

    def _gap(self, now):
        """Polled DRDY: report the conversions since the last serviced one, minus this one."""
        last = self._last
        self._last = now
        if last < 0 or self._on_gap is None:
            return
        # us * SPS / 1e6, rounded: the sim clock is exact to 0.5 us (hal_circuitpython.py for hardware)
        k = (self.ticks_diff(now, last) * self._rate + 500000) // 1000000 - 1
        if k >= 1:
            self._on_gap(k)

    def busy(self, what, n=1):
        c = self.costs.get(what)
        if not c:
            return
        us = c * n
        link = self.link
        link.stall(us, self.polled)
        if self.polled:   # no interrupts: conversions come and go unseen
            link.t_us = (link.t_us + us) & T_MASK
            return
        # a hard IRQ keeps running: the handler services every DRDY inside the stall
        end = link.t_us + us
        left = us
        while left > 0:
            link.idle(left)
            if link.flags & F_DRDY and self._handler is not None:
                self._isr()
            left = self.ticks_diff(end & T_MASK, link.t_us)

    def _isr(self):
        if self._lock:
            _heap_lock()
            try:
                self._handler(None)
            finally:
                _heap_unlock()
        else:
            self._handler(None)

    # serial
    def serial_read(self):
        if not self.link.flags & F_SERIAL:
            return None
        self.link.flags &= ~F_SERIAL
        return self.link.serial_read()

    def serial_write(self, data):
        self.link.serial_write(data)
