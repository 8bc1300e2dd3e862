# Stand-in for MicroPython's `machine` module on the simulated handheld (the rp2 port's),
# written from its documentation (docs.micropython.org: library/machine.Pin,
# library/machine.SPI, rp2/quickref): the signatures, the constants and the refusals
# (unknown keyword arguments, an SPI id or pin the RP2040 does not have, buffers of
# different lengths). Pins and SPI go to simboard's copper; an interrupt handler with
# hard=True runs with the heap locked. Not a module of the desktop package.
import simboard

_board = simboard.board()
_NPINS = 30


class Pin:
    IN = 0
    OUT = 1
    OPEN_DRAIN = 2
    ALT = 3
    PULL_UP = 1
    PULL_DOWN = 2
    IRQ_FALLING = 4
    IRQ_RISING = 8

    def __init__(self, id, mode=-1, pull=-1, *, value=None, drive=0, alt=-1):
        if isinstance(id, str):
            name = id
            id = simboard.LED if id == "LED" else (int(id[2:]) if id[:2] == "GP" and id[2:].isdigit() else -1)
            if id < 0:
                raise ValueError("unknown named pin %r" % name)
        if not isinstance(id, int) or not 0 <= id < _NPINS:
            raise ValueError("invalid pin")
        self._id = id
        self._mode = self.IN
        self.init(mode, pull, value=value, drive=drive, alt=alt)

    def init(self, mode=-1, pull=-1, *, value=None, drive=0, alt=-1):
        if mode != -1:
            if mode not in (self.IN, self.OUT, self.OPEN_DRAIN, self.ALT):
                raise ValueError("invalid pin mode")
            self._mode = mode
        if pull not in (-1, None, self.PULL_UP, self.PULL_DOWN):
            raise ValueError("invalid pull")
        if value is not None:
            self.value(value)

    def value(self, x=None):
        if x is None:
            if self._mode == self.OUT:
                return _board.driven.get(self._id, 0)
            return _board.read(self._id)
        _board.write(self._id, 1 if x else 0)
        return None

    def __call__(self, x=None):
        if x is None:
            return self.value()
        _board.write(self._id, 1 if x else 0)
        return None

    def on(self):
        _board.write(self._id, 1)

    def off(self):
        _board.write(self._id, 0)

    high = on
    low = off

    def irq(self, handler=None, trigger=IRQ_FALLING | IRQ_RISING, hard=False):
        if handler is not None and not callable(handler):
            raise TypeError("handler must be None or callable")
        if self._id == simboard.DRDY and trigger & self.IRQ_FALLING:
            _board.irq_handler = handler
            _board.irq_pin = self
            _board.irq_hard = bool(hard)
        return None

    def __repr__(self):
        return "Pin(GPIO%d)" % self._id


def _no_extra(extra):
    # the C argument parser's own words (mp_arg_parse_all), not a Python function's
    # "unexpected keyword argument": checked on the rp2 firmware in the emulated Pico
    if extra:
        raise TypeError("extra keyword arguments given")


class SPI:
    MSB = 0
    LSB = 1
    # the RP2040's SPI function pins (datasheet 1.4.3): (SCK, MOSI = TX, MISO = RX)
    _PINS = {0: ((2, 6, 18, 22), (3, 7, 19, 23), (0, 4, 16, 20)), 1: ((10, 14, 26), (11, 15, 27), (8, 12, 28))}

    def __init__(self, id, baudrate=1000000, *, polarity=0, phase=0, bits=8, firstbit=MSB, sck=None,
                 mosi=None, miso=None, **extra):
        _no_extra(extra)
        if id not in self._PINS:
            raise ValueError("SPI(%r) doesn't exist" % (id,))
        self._id = id
        self.init(baudrate, polarity=polarity, phase=phase, bits=bits, firstbit=firstbit, sck=sck, mosi=mosi,
                  miso=miso)

    def init(self, baudrate=1000000, *, polarity=0, phase=0, bits=8, firstbit=MSB, sck=None, mosi=None,
             miso=None, **extra):
        _no_extra(extra)
        for pin, allowed, what in ((sck, self._PINS[self._id][0], "SCK"), (mosi, self._PINS[self._id][1], "MOSI"),
                                   (miso, self._PINS[self._id][2], "MISO")):
            if pin is not None and (not isinstance(pin, Pin) or pin._id not in allowed):
                raise ValueError("bad %s pin" % what)
        if polarity not in (0, 1) or phase not in (0, 1):
            raise ValueError("polarity and phase must be 0 or 1")
        if bits != 8:
            raise ValueError("bits must be 8")
        if firstbit != self.MSB:
            raise ValueError("firstbit must be MSB")
        if not 0 < baudrate <= 62500000:
            raise ValueError("bad baudrate")
        _board.set_spi(baudrate, polarity, phase)

    def deinit(self):
        pass

    def read(self, nbytes, write=0x00):
        buf = bytearray(nbytes)
        self.readinto(buf, write)
        return bytes(buf)

    def readinto(self, buf, write=0x00):
        if write:
            _board.transfer(bytes([write]) * len(buf), buf, len(buf))
        else:
            _board.transfer(None, buf, len(buf))

    def write(self, buf):
        _board.transfer(buf, None, len(buf))

    def write_readinto(self, write_buf, read_buf):
        if len(write_buf) != len(read_buf):
            raise ValueError("buffers must be the same length")
        _board.transfer(write_buf, read_buf, len(read_buf))


def idle():
    _board.idle()


def freq(hz=None):
    return 125000000


def unique_id():
    return b"\xf1\x0c\xa1\x00\x00\x00\x00\x01"


def reset():
    # The board restarts: the interpreter stops where it is and the runner powers it on again.
    # SystemExit would not do: a virtual board runs `micropython -i`, whose REPL catches it.
    import os
    os.system("kill -9 $PPID")
    raise SystemExit(0)


def soft_reset():
    raise SystemExit(0)
