"""CircuitPython HAL: busio.SPI, digitalio, keypad; DRDY polled (no user interrupts).

The contract is hal.py. Pins in config.json are board names
("GP18", "D5", ...), looked up in `board`. CircuitPython has no user
interrupts, so `idle()` polls DRDY and calls the handler itself. While the
main loop is busy (a sample ~2 ms, a solve ~0.2 s on an RP2040) conversions
are replaced unread (the ADS1292 keeps only the latest). On the next DRDY the
board measures the time since the last serviced one and reports the unseen
conversions to the driver (`ADS1292Pair.account_gap`): counted in `missed`,
the boxcar kept in phase, the block they hit discarded.

Clock: `time.monotonic_ns()` where the build has long ints (raspberrypi,
espressif): 1/1024 s ticks plus 1/32 subticks, 30.5 us resolution (976.6 us on
ports without subticks). Else `supervisor.ticks_ms()`: ~1 ms (1/1024 s ticks);
at 2000 SPS that leaves the count uncertain by about 2 and gaps under ~2 ms
unseen. The serviced conversion is the latest, up to one period old, and the
one before it was normally serviced promptly by the poll loop, so the count
is floor(elapsed * rate) - 1 (exact then; one low when both services were late).
After each service one byte is clocked with both CS high: DRDY returns high on
the first SCLK (section 8.5.1.6) even for a frame the handler did not read, so the
next low level is the next conversion, never the same one twice.
Serial: usb_cdc.data if enabled in boot.py (a second, binary-clean port),
else the console via supervisor.runtime.serial_bytes_available. After the
`repl` command the contract's default hand_back is enough: Ctrl-C was never
taken, and CircuitPython releases the pins itself when code.py ends.
"""

import sys
import time

import board as _board
import busio
import digitalio
import keypad
import supervisor

import hal

try:
    import usb_cdc
    _data = usb_cdc.data
except (ImportError, AttributeError):
    _data = None

# Serial bytes read per main-loop pass: 100 kB/s of junk discarded at 50 passes a second (as
# hal_micropython.py; the protocol needs >= 50 kB/s, docs/protocol.md)
SERIAL_CHUNK = 2048
_TICKS_PERIOD = 1 << 29      # supervisor.ticks_ms wraps at 2**29 ms
_TICKS_HALF = _TICKS_PERIOD // 2
_GAP_MS_MAX = 131071         # ms * 8000 SPS stays a small int (2**30) without long ints

try:
    _now_ns = time.monotonic_ns   # needs long ints (MPZ): raspberrypi, espressif ports
except AttributeError:
    _now_ns = None                # LONGINT_IMPL = NONE builds: supervisor.ticks_ms
_RES_US = 31                      # monotonic_ns resolution, 1/32768 s


def _pin(name):
    """A board pin from config.json: a board name ("GP18", "D5"), or a GPIO number, which is
    the board's GP<n> (the names of RP2040 boards, so the defaults' Pico wiring works as is)."""
    if isinstance(name, int):
        key = "GP%d" % name
        if not hasattr(_board, key):
            raise ValueError("pin %d: this board has no %s; set the pins by board name in config.json"
                             % (name, key))
        name = key
    return getattr(_board, name)


class Board(hal.Board):
    polls_drdy = True   # idle() polls the pin: conversions pass unseen while the main loop works

    def __init__(self, cfg, root="/"):
        self.root = root if root != "/" else ""
        self.name = "circuitpython-" + sys.platform
        self._rbuf = bytearray(SERIAL_CHUNK)
        self.spi = busio.SPI(_pin(cfg["pin_sck"]), MOSI=_pin(cfg["pin_mosi"]), MISO=_pin(cfg["pin_miso"]))
        while not self.spi.try_lock():
            pass
        self.set_spi_rate(self.REG_BAUD)
        self._cs = []
        for key in ("pin_cs0", "pin_cs1"):
            p = digitalio.DigitalInOut(_pin(cfg[key]))
            p.switch_to_output(value=True)
            self._cs.append(p)
        self._start = digitalio.DigitalInOut(_pin(cfg["pin_start"]))
        self._start.switch_to_output(value=False)
        self._reset = digitalio.DigitalInOut(_pin(cfg["pin_reset"]))
        self._reset.switch_to_output(value=True)
        self._drdy = digitalio.DigitalInOut(_pin(cfg["pin_drdy"]))
        self._drdy.switch_to_input(pull=digitalio.Pull.UP)
        self._led = digitalio.DigitalInOut(_pin(cfg["pin_led"]))
        self._led.switch_to_output(value=False)
        # keypad debounces in the background and queues edges
        self._keys = keypad.Keys((_pin(cfg["pin_button"]),), value_when_pressed=False, pull=True)
        self._pressed = False
        self._handler = None
        self._rate = 0
        self._on_gap = None
        self._last = None           # clock at the last serviced DRDY
        self._clk1 = bytearray(1)   # one SCLK byte with CS high releases DRDY

    def set_spi_rate(self, hz):
        self.spi.configure(baudrate=hz, polarity=0, phase=1, bits=8)  # mode 1, §8.5.1.3

    def spi_write(self, chip, buf, n):
        cs = self._cs[chip]
        cs.value = False
        try:
            self.spi.write(buf, end=n)
        finally:
            cs.value = True

    def spi_write_readinto(self, chip, wbuf, rbuf, n):
        cs = self._cs[chip]
        cs.value = False
        try:
            self.spi.write_readinto(wbuf, rbuf, out_end=n, in_end=n)
        finally:
            cs.value = True

    def spi_readinto(self, chip, buf):
        cs = self._cs[chip]
        cs.value = False
        self.spi.readinto(buf, write_value=0)
        cs.value = True

    def set_start(self, v):
        self._start.value = bool(v)

    def set_reset(self, v):
        self._reset.value = bool(v)

    def led(self, on):
        self._led.value = bool(on)

    def button(self):
        ev = self._keys.events.get()
        while ev is not None:
            self._pressed = ev.pressed
            ev = self._keys.events.get()
        return self._pressed

    def attach_drdy(self, handler, rate=0, on_gap=None):
        self._handler = handler
        self._rate = rate
        self._on_gap = on_gap
        self._last = None   # conversions (re)started: nothing to measure from yet

    def ticks_ms(self):
        return supervisor.ticks_ms()

    def ticks_diff(self, a, b):
        return ((a - b + _TICKS_HALF) & (_TICKS_PERIOD - 1)) - _TICKS_HALF

    def sleep_us(self, us):
        time.sleep(us / 1e6)

    def time(self):
        t = time.time()
        return t if t > 1600000000 else None

    def idle(self):
        # Poll: DRDY low is a conversion not yet serviced (released after each one)
        if self._drdy.value or self._handler is None:
            return
        if self._on_gap is not None:
            self._gap()
        self._handler(None)
        self.spi.write(self._clk1)   # all CS high: only releases DRDY (section 8.5.1.6)

    def _gap(self):
        """Report the conversions that came and went since the last serviced DRDY."""
        rate = self._rate
        last = self._last
        if _now_ns is not None:
            now = _now_ns() // 1000
            self._last = now
            if last is None:
                return
            k = (now - last + _RES_US) * rate // 1000000 - 1
        else:
            now = supervisor.ticks_ms()
            self._last = now
            if last is None:
                return
            ms = min(self.ticks_diff(now, last), _GAP_MS_MAX)
            # only what the 1 ms clock can tell: more than 1.5 periods beyond its resolution
            if ms * rate < 1500 + rate:
                return
            k = (ms * rate + 500) // 1000 - 1
        if k >= 1:
            self._on_gap(k)

    def serial_read(self):
        """What arrived, up to SERIAL_CHUNK bytes (a bytearray), or None.

        The USB receive FIFO holds 64 bytes (TinyUSB's full-speed default) and the host
        refills it as it is read, so the data port is read while it has bytes waiting, each
        read no more than are there (it would wait for the rest)."""
        if _data is None:       # the console: no second port enabled in boot.py
            n = supervisor.runtime.serial_bytes_available
            return sys.stdin.read(min(n, SERIAL_CHUNK)).encode() if n else None
        buf = self._rbuf
        n = 0
        while n < SERIAL_CHUNK:
            k = min(_data.in_waiting, SERIAL_CHUNK - n)
            if not k:
                break
            n += _data.readinto(memoryview(buf)[n:n + k])
        return buf[:n] if n else None

    def serial_write(self, data):
        if _data is not None:
            _data.write(data)
        else:
            sys.stdout.write(bytes(data).decode())
