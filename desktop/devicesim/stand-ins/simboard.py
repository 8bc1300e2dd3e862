# The simulated handheld's circuit board, under the stand-ins for a board's C modules.
#
# Runs inside the interpreter (MicroPython or CircuitPython), beside the firmware; not a
# module of the desktop package. The stand-ins (micropython/: machine, time;
# circuitpython/: board, microcontroller, digitalio, busio, keypad, supervisor, usb_cdc,
# storage, time) keep the documented behaviour and refusals of the modules they stand in
# for; this module is the copper between them and the world: which GPIO goes to which pin
# of the two ADS1292, the button and the LED (the Pico wiring of device/config.py's
# defaults), and the simulation link (device/sim/sim_link.py, device/sim/sim_wire.py) over the two
# file descriptors named in FLUXCAL_SIMBOARD_FDS, which the desktop's World answers
# (desktop/devicesim/runners.py, BoardDevice).
#
# Time is the World's. It passes in waits (machine.idle, reading a polled input, sleeps)
# and while SPI bytes are clocked, not while Python code runs: a stand-in cannot show the
# CPU's own time, the electrical timing of the pins or the real SPI clock's edges.
import os

from sim_link import PipeLink
from sim_wire import F_BUTTON, F_DRDY, F_DRDY_LOW, NO_CHIP, PIN_LED, PIN_RESET, PIN_START, T_MASK

try:
    from micropython import heap_lock, heap_unlock
except ImportError:
    heap_lock = heap_unlock = None

# GPIO numbers of the nets (device/config.py: pin_sck, pin_mosi, ...)
SCK = 18
MOSI = 19
MISO = 16
CS0 = 17
CS1 = 20
DRDY = 21
START = 22
RESET = 26
BUTTON = 15      # to ground when pressed, pulled up
LED = 25
SPI_PINS = (SCK, MOSI, MISO)
# A read of DRDY (a polled input) returns when DRDY is or goes low, else after POLL_US:
# a polling loop on a board finds the conversion a few tens of us late at worst, which
# moves no sample (the frame is read before the next conversion either way), and one
# link round trip per conversion keeps the simulation as fast as with an interrupt.
POLL_US = 1000

_board = None


def board():
    global _board
    if _board is None:
        _board = Board()
    return _board


class Board:
    def __init__(self):
        fds = os.getenv("FLUXCAL_SIMBOARD_FDS")
        if not fds:
            raise OSError("no simulated board here (FLUXCAL_SIMBOARD_FDS is not set)")
        r, w = fds.split(",")
        self.link = PipeLink(open("/dev/fd/" + r, "rb"), open("/dev/fd/" + w, "wb"))
        self.cs = bytearray(b"\x01\x01")   # both chip selects high
        self.driven = {}                   # GPIO -> level the MCU drives on it
        self.spi_mode_ok = False           # the ADS1292 samples DIN on SCLK's falling edge: mode 1
        self.irq_handler = None            # DRDY's falling-edge handler, and its pin object
        self.irq_pin = None
        self.irq_hard = False
        self.phase = "boot"                # "boot" while boot.py runs, then "main"
        self.claimed = {}                  # GPIO -> what holds it (CircuitPython's 'in use')
        self._last_us = 0
        self.now_us = 0                    # microseconds since power-up, never wraps

    # ****** pins ******
    def write(self, gpio, level):
        """The MCU drives `gpio` to `level` (0 or 1). Allocation-free for CS (IRQ path)."""
        if gpio == CS0:
            self.cs[0] = level
            return
        if gpio == CS1:
            self.cs[1] = level
            return
        if gpio == START:
            self.link.pin(PIN_START, level)
        elif gpio == RESET:
            self.link.pin(PIN_RESET, level)
        elif gpio == LED:
            self.link.pin(PIN_LED, level)
        self.driven[gpio] = level

    def read(self, gpio):
        """The level on `gpio`. Reading DRDY is a poll (see POLL_US)."""
        if gpio == DRDY:
            self.link.poll(POLL_US)
            self._clock()
            return 0 if self.link.flags & F_DRDY_LOW else 1
        if gpio == BUTTON:
            return 0 if self.link.flags & F_BUTTON else 1
        return self.driven.get(gpio, 1)

    def pressed(self):
        return bool(self.link.flags & F_BUTTON)

    # ****** SPI: both chips on one bus, one CS each ******
    def transfer(self, wbuf, rbuf, n):
        """Clock n bytes (DIN low when wbuf is None) to the selected chip. Allocation-free."""
        c0 = self.cs[0]
        c1 = self.cs[1]
        chip = NO_CHIP if c0 and c1 else (0 if not c0 else 1)
        self.link.xfer(chip, wbuf, rbuf, n)
        if rbuf is not None and not self.spi_mode_ok:
            for i in range(n):      # sampled on the wrong edge: every bit one late
                rbuf[i] = ((rbuf[i] >> 1) | 0x80) & 0xFF

    def set_spi(self, baudrate, polarity, phase):
        self.spi_mode_ok = polarity == 0 and phase == 1
        self.link.set_baud(baudrate)

    # ****** time, waits and the interrupt ******
    def _clock(self):
        t = self.link.t_us
        self.now_us += (t - self._last_us) & T_MASK
        self._last_us = t

    def idle(self):
        """Wait for the next event (the core sleeps until an interrupt): DRDY, the button."""
        self.link.idle()
        self._clock()
        if self.link.flags & F_DRDY and self.irq_handler is not None:
            if self.irq_hard and heap_lock is not None:
                heap_lock()      # a hard IRQ may not allocate
                try:
                    self.irq_handler(self.irq_pin)
                finally:
                    heap_unlock()
            else:
                self.irq_handler(self.irq_pin)

    def sleep_ms(self, ms):
        """time.sleep_ms as the port's mp_hal_delay_ms: the core waits for interrupts until the
        deadline, so the DRDY handler runs meanwhile (app.App.wait sleeps between passes). Each
        idle() ends at the next DRDY or the 1 ms tick; the count bounds a world that stands still."""
        end = self.now_us + ms * 1000
        n = 4 * ms + 4
        while self.now_us < end and n > 0:
            self.idle()
            n -= 1

    def sleep_us(self, us):
        if us > 0:
            self.link.sleep_us(us)
            self.link.t_us = (self.link.t_us + us) & T_MASK
            self._clock()


def power_on(runtime, main=True):
    """Boot as the board does: boot.py, then main.py (MicroPython) or code.py (CircuitPython),
    from the flash (the current folder). main=False: a soft reset from the raw REPL, which
    runs boot.py only (the REPL is what the user asked for)."""
    b = board()
    names = ("boot.py", "code.py" if runtime == "circuitpython" else "main.py") if main else ("boot.py",)
    for name in names:
        try:
            with open(name) as fh:
                source = fh.read()
        except OSError:
            continue
        b.phase = "boot" if name == "boot.py" else "main"
        exec(source, {"__name__": "__main__"})
