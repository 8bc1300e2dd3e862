"""MicroPython HAL (rp2, stm32, esp32): machine.SPI mode 1, DRDY on Pin.irq (rp2: a PIO counter).

The contract is hal.py. DRDY uses a hard IRQ where the port
accepts `hard=True` (rp2, stm32); esp32's Pin.irq has no `hard` argument and
always schedules the handler (a soft IRQ: it may run a few ms late, which the
ring absorbs). USB serial is sys.stdin/sys.stdout with Ctrl-C disabled while
the app runs, so a stray 0x03 on the wire cannot stop the instrument; the
`repl` command ends the app and turns Ctrl-C back on (hand_back), so mpremote
can take the line without the button.

On rp2 a PIO state machine counts the DRDY falls the boxcar does not read (count_drdy,
_drdy_counter): the hard IRQ, about 1.5 k cycles a conversion on an RP2040 before any handler
code (the port's GPIO interrupt and MicroPython's dispatch), then comes only for the `window`
conversions of every `decim` that are read (2 in 10 by default), from the state machine's
IRQ flag (PIO0_IRQ_0) instead of the pin's.

The watchdog (RP2040 only, see _rp2040): the app starts machine.WDT and feeds it
once a main-loop pass, so a hung loop resets the board (bootguard.py counts the
reset). It cannot be stopped, so from `repl` on a machine.Timer feeds it while
the REPL has the line, and boot.py calls keep_watchdog_fed() after every reset:
a soft reset (mpremote's, at each step of a deploy) keeps the watchdog running
but ends the timer.
"""

import sys
import time
from array import array

import machine
import micropython

import hal

try:
    import select
except ImportError:
    select = None

# Serial bytes read per main-loop pass: at 50 passes a second, up to 100 kB/s of junk discarded
# (the protocol asks >= 50 kB/s, docs/protocol.md). A flood lengthens a pass by a bounded
# amount, which the DRDY ring absorbs (128 blocks: 1.28 s at the default rate and decimation).
SERIAL_CHUNK = 2048

# The RP2040's watchdog registers (datasheet 4.7.6): CTRL bit 30 ENABLE (a watchdog runs), REASON
# bit 0 TIMER (the last reset was its count running out; machine.reset() sets FORCE, and
# machine.reset_cause() says WDT_RESET for both). Other ports' watchdogs are not started: the
# firmware could not tell after a soft reset that one runs (docs/limits.md).
_WATCHDOG_CTRL = 0x40058000
_WATCHDOG_REASON = 0x40058008
_ENABLE = 1 << 30
_TIMER = 1
_REPL_WATCHDOG_MS = 8388   # the RP2040's longest timeout: the leash while the REPL has the line
_REPL_FEED_MS = 1000       # the timer's period: seven of its callbacks may run late or be lost

_feeder = None             # the Timer feeding the watchdog while the REPL has the line


def _rp2040():
    return sys.platform == "rp2" and "RP2040" in sys.implementation._machine


def _feed_from_timer():
    """Feed the running watchdog from a soft timer callback, which runs between bytecodes and
    while the REPL waits for input: through mpremote's raw REPL and a person's typing."""
    global _feeder
    wdt = machine.WDT(timeout=_REPL_WATCHDOG_MS)   # on rp2 this reloads the running one
    _feeder = machine.Timer(period=_REPL_FEED_MS, callback=lambda t: wdt.feed())


def keep_watchdog_fed():
    """boot.py, after every reset: a watchdog running now was started before a soft reset, whose
    timers are gone: feed it until the app takes it over (Board.watchdog_start)."""
    if _rp2040() and machine.mem32[_WATCHDOG_CTRL] & _ENABLE:
        _feed_from_timer()


def _drdy_counter():
    """The PIO program that counts DRDY falls (rp2 only; None elsewhere). Fed two words before
    it starts: skip - 1 and window - 1 (skip >= 1, window >= 1). A fall is a high then a low
    level on the pin (its in_base): the ADS1292's DRDY rises before each conversion ends,
    4 tCLK ahead at the latest if the last one was not read [DS §8.5.1.5]."""
    try:
        import rp2
    except ImportError:
        return None
    asm = rp2.asm_pio

    @asm()
    def counter():
        pull()                  # skip - 1
        mov(y, osr)
        pull()                  # window - 1: stays in the OSR
        wrap_target()
        mov(x, y)
        label("skip")
        wait(1, pin, 0)
        wait(0, pin, 0)         # a conversion the boxcar does not read
        jmp(x_dec, "skip")
        mov(x, osr)
        label("read")
        wait(1, pin, 0)
        wait(0, pin, 0)
        irq(rel(0))             # one it reads: the handler, hard IRQ
        jmp(x_dec, "read")
        wrap()
    return counter


try:
    micropython.alloc_emergency_exception_buf(100)  # a traceback from the ISR, not a second fault
except AttributeError:  # a port without the emergency buffer (the unix port)
    pass


class Board(hal.Board):
    sleeps_with_irq = True   # Pin.irq runs the DRDY handler inside time.sleep_ms (hard or scheduled)

    def __init__(self, cfg, root="/"):
        P = machine.Pin
        self.root = root if root != "/" else ""
        self.name = "micropython-" + sys.platform
        self._spi_id = cfg["spi_id"]
        self._pins = (P(cfg["pin_sck"]), P(cfg["pin_mosi"]), P(cfg["pin_miso"]))
        self.spi = None
        self._cs = (P(cfg["pin_cs0"], P.OUT, value=1), P(cfg["pin_cs1"], P.OUT, value=1))
        # the native DRDY handler's reads (hal.Board.drdy_bus): the Pins, and readinto from set_spi_rate
        self.drdy_bus = [self._cs[0], self._cs[1], None]
        self.set_spi_rate(self.REG_BAUD)
        self._start = P(cfg["pin_start"], P.OUT, value=0)
        self._reset = P(cfg["pin_reset"], P.OUT, value=1)
        self._drdy = P(cfg["pin_drdy"], P.IN, P.PULL_UP)
        self._button = P(cfg["pin_button"], P.IN, P.PULL_UP)  # active low to GND
        # its closings timed by a hard IRQ (the main loop's pass may come 40 ms later, app.py):
        # ticks_ms of the last one, 1 until button_edge takes it
        self._closed = array("i", [0, 0])
        try:
            try:
                self._button.irq(handler=self._button_closed, trigger=P.IRQ_FALLING, hard=True)
            except TypeError:   # esp32: no hard IRQs; the handler is scheduled (within a ms or so)
                self._button.irq(handler=self._button_closed, trigger=P.IRQ_FALLING)
            self.button_edges = True
        except (AttributeError, ValueError, OSError):   # no interrupt on this pin: polled alone
            pass
        self._led = P(cfg["pin_led"], P.OUT, value=0)
        self._poll = None
        if select is not None:
            self._poll = select.poll()
            self._poll.register(sys.stdin, select.POLLIN)
        self._rbuf = bytearray(SERIAL_CHUNK)
        self._one = bytearray(1)
        self._wdt = None
        self._handler = None       # the DRDY handler attached (None: none)
        self._count = None         # (skip, window) the PIO counts (count_drdy), None: Pin.irq
        self._sm = None            # the counting state machine, once made
        # App.wait calls idle() on every conversion: the C function itself, not a method around it.
        # So too the clock and the pass's sleep: the main loop reads the clock several times a pass
        # and the survey every sample, and a method around a C function is a Python frame a call
        # (about 1 k cycles on an RP2040); loaded from the instance, no bound method is allocated
        self.idle = machine.idle
        self.ticks_ms = time.ticks_ms
        self.ticks_diff = time.ticks_diff
        self.sleep_ms = time.sleep_ms
        try:
            micropython.kbd_intr(-1)
        except AttributeError:
            pass

    # bus
    def set_spi_rate(self, hz):
        sck, mosi, miso = self._pins
        # CPOL=0, CPHA=1: DIN latched on the falling edge (§8.5.1.3-4)
        self.spi = machine.SPI(self._spi_id, baudrate=hz, polarity=0, phase=1, bits=8,
                               firstbit=machine.SPI.MSB, sck=sck, mosi=mosi, miso=miso)
        self._write = self.spi.write
        self._readinto = self.spi.readinto
        self.drdy_bus[2] = self._readinto     # in place: the handler holds the list

    def _view(self, buf, n):
        if n == len(buf):
            return buf
        return memoryview(buf)[:n]

    def spi_write(self, chip, buf, n):
        cs = self._cs[chip]
        cs(0)
        try:
            self._write(self._view(buf, n))
            time.sleep_us(8)   # 4 tCLK after the last SCLK before CS rises (§8.5.2)
        finally:
            cs(1)

    def spi_write_readinto(self, chip, wbuf, rbuf, n):
        cs = self._cs[chip]
        cs(0)
        try:
            self.spi.write_readinto(self._view(wbuf, n), self._view(rbuf, n))
            time.sleep_us(8)
        finally:
            cs(1)

    def spi_readinto(self, chip, buf):
        # ISR path: no allocation (bound methods cached in set_spi_rate)
        cs = self._cs[chip]
        cs(0)
        self._readinto(buf, 0)   # DIN held low while reading (§8.5.1.5)
        cs(1)

    # pins
    def set_start(self, v):
        self._start(1 if v else 0)

    def set_reset(self, v):
        self._reset(1 if v else 0)

    def led(self, on):
        self._led(1 if on else 0)

    def button(self):
        return self._button() == 0

    def _button_closed(self, _pin):
        # a hard IRQ: nothing allocated (a small int into the array)
        c = self._closed
        c[0] = time.ticks_ms()
        c[1] = 1

    def button_edge(self, now):
        c = self._closed
        if c[1] and time.ticks_diff(now, c[0]) <= hal.EDGE_MS:
            c[1] = 0
            return c[0]
        return now

    def attach_drdy(self, handler, rate=0, on_gap=None):
        # rate and on_gap are for polling HALs: a hard IRQ sees every DRDY,
        # and during a main-loop stall the ring absorbs the samples (docs/firmware.md)
        self._handler = handler
        if self._sm is not None:
            self._sm.active(0)
            self._sm.irq(None)
        if handler is not None and self._count is not None:
            self._drdy.irq(handler=None)
            self._start_counter(handler)
            return
        try:
            self._drdy.irq(handler=handler, trigger=machine.Pin.IRQ_FALLING, hard=True)
        except TypeError:  # esp32: no hard IRQs; the handler is scheduled
            self._drdy.irq(handler=handler, trigger=machine.Pin.IRQ_FALLING)

    def count_drdy(self, skip, window):
        # hal.Board.count_drdy: on rp2, a PIO state machine (_drdy_counter)
        if skip < 1 or (self._sm is None and not self._make_counter()):
            self._count = None
        else:
            self._count = (skip, window)
        if self._handler is not None:
            self.attach_drdy(self._handler)     # restarted: from the next fall on
        return self._count is not None

    def _make_counter(self):
        prog = _drdy_counter()
        if prog is None:
            return False
        import rp2
        self._sm = rp2.StateMachine(0, prog, in_base=self._drdy)
        self._prog = prog
        return True

    def _start_counter(self, handler):
        sm = self._sm
        sm.init(self._prog, in_base=self._drdy)    # stopped, FIFOs empty, at the program's start
        sm.put(self._count[0] - 1)
        sm.put(self._count[1] - 1)
        sm.irq(handler, hard=True)
        sm.active(1)

    # time: the contract's methods, which __init__ shadows on the instance with time's own functions
    def ticks_ms(self):
        return time.ticks_ms()

    def ticks_diff(self, a, b):
        return time.ticks_diff(a, b)

    def sleep_ms(self, ms):
        time.sleep_ms(ms)

    def sleep_us(self, us):
        time.sleep_us(us)

    def time(self):
        t = time.time()
        # no RTC set: unknown. An unset rp2 clock reads 2021-01-01 (1609459200, epoch 1970),
        # others 2000-01-01: anything before 2022 was never set
        return t if t >= 1640995200 else None

    def idle(self):
        machine.idle()   # sleeps until the next interrupt (DRDY within 1/rate s)

    # watchdog
    def watchdog_start(self, ms):
        global _feeder
        if not _rp2040():
            return False
        if _feeder is not None:        # boot.py's timer: from now on only the main loop feeds it
            _feeder.deinit()
            _feeder = None
        self._wdt = machine.WDT(timeout=ms)
        self.watchdog_feed = self._wdt.feed   # the C method itself, once a pass
        return True

    def reset_by_watchdog(self):
        return _rp2040() and bool(machine.mem32[_WATCHDOG_REASON] & _TIMER)

    def hand_back(self):
        self.attach_drdy(None)         # the REPL has no use for the DRDY handler
        try:
            micropython.kbd_intr(3)    # Ctrl-C interrupts again: how mpremote gets in
        except AttributeError:
            pass
        if self._wdt is not None:      # it cannot be stopped: fed while the REPL has the line
            _feed_from_timer()

    # serial (USB CDC)
    def serial_read(self):
        """What arrived, up to SERIAL_CHUNK bytes (a bytearray), or None.

        stdin tells only whether a byte is waiting, and a read of more than is there blocks,
        so one byte at a time, while poll says one is waiting: ipoll and readinto allocate
        nothing per byte (poll() and read(1) allocated two objects each). The usual pass, nothing
        waiting, stays within the 11 words of frame MicroPython keeps off the heap (app.py, Frames)."""
        p = self._poll
        if p is not None:
            for _ready in p.ipoll(0):
                return self._read_waiting(p.ipoll)
        return None

    def _read_waiting(self, ipoll):
        rd = sys.stdin.buffer.readinto
        one = self._one
        buf = self._rbuf
        n = 0
        while n < SERIAL_CHUNK:
            if not rd(one, 1):
                break           # end of input (a closed pty)
            buf[n] = one[0]
            n += 1
            for _ready in ipoll(0):
                break
            else:
                break           # nothing more waiting
        return buf[:n] if n else None

    def serial_write(self, data):
        sys.stdout.buffer.write(data)
