"""Simulation HAL: the board seen through a link to the desktop ADS1292 emulator.

This module also documents the HAL contract every hal_*.py implements:

    REG_BAUD, DATA_BAUD          SPI clock for register access / data reads
    set_spi_rate(hz)
    spi_write(chip, buf, n)      CS low, clock out buf[:n], CS high
    spi_write_readinto(chip, w, r, n)
    spi_readinto(chip, buf)      CS low, clock in len(buf) bytes (DIN low), CS high
    set_start(v), set_reset(v)   shared START and PWDN/RESET lines
    attach_drdy(handler, rate, on_gap)
                                 handler(pin) on DRDY falling edge. A polling HAL
                                 (no user interrupts) also calls on_gap(frames)
                                 from the main loop, before the handler, when
                                 conversions at `rate` SPS passed unseen; a HAL
                                 with DRDY interrupts ignores rate and on_gap
    button() -> bool             True while pressed
    led(on)
    ticks_ms(), ticks_us(), ticks_diff(a, b), sleep_us(n), sleep_ms(n)
    idle()                       wait for the next event (DRDY, serial, button)
    busy(what, n)                the main loop just did n units of work `what`
                                 ("solve", "sample_cal", "sample"): a no-op on
                                 hardware, charged as simulated time here
    serial_read() -> bytes|None  non-blocking; serial_write(data)
    root                         directory for cal/config/log files
    time() -> int|None           wall clock seconds (None when unknown)
    name                         runtime name for `version`

Two links implement the wire: PipeLink (this file) speaks to
desktop/devicesim/bridge.py over stdin/stdout when the firmware runs in the
real `micropython` executable; desktop/devicesim/world.py provides an
in-process link object with the same methods when the firmware runs in
CPython. Simulated time only advances on the host, so runs are deterministic.

Main-loop time. The host cannot see how long the firmware computes, so the
board charges a cost model instead: `costs` maps a `busy` key to simulated
microseconds per unit (desktop/devicesim/runner.py holds the defaults, the
measured unix-port costs x 40). A charged stall lets chip time pass. With
`polled` False (a hard IRQ, MicroPython) the DRDY handler still runs for every
conversion inside the stall, as an interrupt would; with `polled` True
(CircuitPython) it does not, and on the next DRDY the board measures the time
since the last serviced one and reports round(elapsed * rate) - 1 unseen
conversions to on_gap, as hal_circuitpython.py does on hardware.

Wire format (little endian). Request: op(1) arg(1) len(2) payload.
    b"X" chip n, payload n bytes -> reply n bytes   (SPI transaction, CS framed)
    b"Z" chip n, no payload      -> reply n bytes   (read with DIN low)
    b"I" 0 0                     -> reply 8 bytes: t_us u32, flags u8, pending u16, 0
    b"J" 0 4, u32 us             -> as "I", but returns after at most us (a stall
                                    in IRQ mode; the host's run budget does not stop it)
    b"R" 0 0                     -> reply len u16 + bytes (serial from host)
    b"W" 0 n, n bytes              one way: serial to host
    b"P" pin v                     one way: pin write (0 START, 1 RESET, 2 LED)
    b"S" 0 4, u32 us               one way: busy-wait n microseconds
    b"B" 0 4, u32 hz               one way: SPI clock (sets the emulator's byte time)
    b"L" 0 n, n bytes              one way: a log line for the host (stderr)
    b"T" a 4, u32 us               one way: a charged stall of us starts (recorded by
                                   the host); a=1 (polled): the host lets the time pass
Idle flags: bit0 DRDY low, bit1 button pressed, bit2 serial pending, bit3 quit.
"""

import sys

try:
    import micropython
    _heap_lock = micropython.heap_lock
    _heap_unlock = micropython.heap_unlock
except (ImportError, AttributeError):  # CPython
    _heap_lock = _heap_unlock = None

_PIN_START = 0
_PIN_RESET = 1
_PIN_LED = 2
_F_DRDY = 1
_F_BUTTON = 2
_F_SERIAL = 4
_F_QUIT = 8
_TICKS_MASK = 0x3FFFFFFF   # ticks wrap like MicroPython's: a power of two period
_TICKS_HALF = 0x20000000


class PipeLink:
    """Binary messages over stdin/stdout to the CPython bridge (MicroPython side)."""

    def __init__(self):
        self._r = sys.stdin.buffer.readinto
        self._w = sys.stdout.buffer.write
        self._flush = getattr(sys.stdout.buffer, "flush", None)
        self._hdr = bytearray(4)
        self._idle = bytearray(8)
        self._len = bytearray(2)
        self._zero = bytearray(16)
        self.t_us = 0
        self.flags = 0
        self.pending = 0

    def _send(self, op, arg, n):
        h = self._hdr
        h[0] = op
        h[1] = arg
        h[2] = n & 0xFF
        h[3] = n >> 8
        self._w(h)

    def _read(self, buf, n):
        got = self._r(buf) if n == len(buf) else self._r(memoryview(buf)[:n])
        while got < n:  # pipes may split a reply; rare, and allocates (not in ISR tests)
            k = self._r(memoryview(buf)[got:n])
            if not k:
                raise OSError("simulator link closed")
            got += k

    def xfer(self, chip, wbuf, rbuf, n):
        if wbuf is None:
            self._send(0x5A, chip, n)  # "Z"
        else:
            self._send(0x58, chip, n)  # "X"
            self._w(wbuf if n == len(wbuf) else memoryview(wbuf)[:n])
        if rbuf is None:
            rbuf = self._zero
        self._read(rbuf, n)

    def idle(self, max_us=0):
        if max_us:
            self._send(0x4A, 0, 4)  # "J"
            self._w(bytes((max_us & 0xFF, (max_us >> 8) & 0xFF, (max_us >> 16) & 0xFF, (max_us >> 24) & 0xFF)))
        else:
            self._send(0x49, 0, 0)  # "I"
        b = self._idle
        self._read(b, 8)
        self.t_us = b[0] | (b[1] << 8) | (b[2] << 16) | ((b[3] & 0x3F) << 24)
        self.flags = b[4]
        self.pending = b[5] | (b[6] << 8)

    def serial_read(self):
        self._send(0x52, 0, 0)  # "R"
        self._read(self._len, 2)
        n = self._len[0] | (self._len[1] << 8)
        if not n:
            return b""
        buf = bytearray(n)
        self._read(buf, n)
        return bytes(buf)

    def serial_write(self, data):
        for i in range(0, len(data), 4096):
            part = data[i:i + 4096]
            self._send(0x57, 0, len(part))  # "W"
            self._w(part)

    def pin(self, which, value):
        self._send(0x50, which, value)  # "P"

    def sleep_us(self, us):
        self._send(0x53, 0, 4)  # "S"
        self._w(bytes((us & 0xFF, (us >> 8) & 0xFF, (us >> 16) & 0xFF, (us >> 24) & 0xFF)))

    def stall(self, us, advance):
        self._send(0x54, 1 if advance else 0, 4)  # "T"
        self._w(bytes((us & 0xFF, (us >> 8) & 0xFF, (us >> 16) & 0xFF, (us >> 24) & 0xFF)))

    def set_baud(self, hz):
        self._send(0x42, 0, 4)  # "B"
        self._w(bytes((hz & 0xFF, (hz >> 8) & 0xFF, (hz >> 16) & 0xFF, (hz >> 24) & 0xFF)))

    def log(self, text):
        data = text.encode()
        self._send(0x4C, 0, len(data))  # "L"
        self._w(data)


class Board:
    """The HAL over a link (PipeLink, or the host's in-process link)."""

    REG_BAUD = 1000000    # <= 2 fCLK = 1.024 MHz during register access, §8.3.7
    DATA_BAUD = 8000000   # RDATAC reads may run up to 20 MHz (tSCLK 50 ns, §6.6)

    def __init__(self, link, root=".", lock_heap_in_isr=False, polled=False, costs=None):
        self.link = link
        self.root = root
        self.name = "sim-" + sys.implementation.name + ("-polled" if polled else "")
        self.baud = self.REG_BAUD
        self.polled = polled
        self.costs = dict(costs or {})   # busy key -> simulated us per unit
        self._handler = None
        self._rate = 0
        self._on_gap = None
        self._last = -1        # t_us of the last serviced DRDY (polled), -1: none yet
        self._led = -1
        self._t0 = 0
        # Under MicroPython: run the DRDY handler with the heap locked, which is
        # what a hard IRQ enforces; an allocation there raises MemoryError.
        self._lock = lock_heap_in_isr and _heap_lock is not None
        self.link.idle()

    # bus
    def set_spi_rate(self, hz):
        self.baud = hz
        self.link.set_baud(hz)

    def spi_write(self, chip, buf, n):
        self.link.xfer(chip, buf, None, n)

    def spi_write_readinto(self, chip, wbuf, rbuf, n):
        self.link.xfer(chip, wbuf, rbuf, n)

    def spi_readinto(self, chip, buf):
        self.link.xfer(chip, None, buf, len(buf))

    # pins
    def set_start(self, v):
        self.link.pin(_PIN_START, 1 if v else 0)

    def set_reset(self, v):
        self.link.pin(_PIN_RESET, 1 if v else 0)

    def led(self, on):
        v = 1 if on else 0
        if v != self._led:
            self._led = v
            self.link.pin(_PIN_LED, v)

    def button(self):
        return bool(self.link.flags & _F_BUTTON)

    def attach_drdy(self, handler, rate=0, on_gap=None):
        self._handler = handler
        self._rate = rate
        self._on_gap = on_gap
        self._last = -1   # (re)started conversions: no gap to measure yet

    # time: simulated, advanced by the host only
    def ticks_us(self):
        return self.link.t_us

    def ticks_ms(self):
        return (self.link.t_us // 1000) & _TICKS_MASK

    def ticks_diff(self, a, b):
        return ((a - b + _TICKS_HALF) & _TICKS_MASK) - _TICKS_HALF

    def sleep_us(self, us):
        self.link.sleep_us(us)
        self.link.t_us = (self.link.t_us + us) & _TICKS_MASK

    def sleep_ms(self, ms):
        self.sleep_us(ms * 1000)

    def time(self):
        return None

    def quit_requested(self):
        return bool(self.link.flags & _F_QUIT)

    def idle(self):
        link = self.link
        link.idle()
        if link.flags & _F_DRDY and self._handler is not None:
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
            link.t_us = (link.t_us + us) & _TICKS_MASK
            return
        # a hard IRQ keeps running: the handler services every DRDY inside the stall
        end = link.t_us + us
        left = us
        while left > 0:
            link.idle(left)
            if link.flags & _F_DRDY and self._handler is not None:
                self._isr()
            left = self.ticks_diff(end & _TICKS_MASK, link.t_us)

    def _isr(self):
        if self._handler is not None:
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
        if not self.link.flags & _F_SERIAL:
            return None
        self.link.flags &= ~_F_SERIAL
        return self.link.serial_read()

    def serial_write(self, data):
        self.link.serial_write(data)

    def log(self, text):
        self.link.log(text)


def main(root, lock_heap_in_isr=False, polled=False, costs=None):
    """Entry point under the `micropython` executable (desktop/devicesim/runner.py).

    stdout is the link, so a traceback must go to stderr, never to stdout.
    """
    try:
        import app
        board = Board(PipeLink(), root, lock_heap_in_isr, polled, costs)
        app.App(board).run()
    except BaseException as e:  # noqa: B036 - report anything, then exit non-zero
        if hasattr(sys, "print_exception"):
            sys.print_exception(e, sys.stderr)
        sys.exit(1)
