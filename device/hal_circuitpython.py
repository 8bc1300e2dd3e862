"""CircuitPython HAL: busio.SPI, digitalio, keypad; DRDY polled (no user interrupts).

The contract is documented in hal_sim.py. Pins in config.json are board names
("GP18", "D5", ...), looked up in `board`. CircuitPython has no user
interrupts, so `idle()` polls DRDY and calls the handler itself; at 2000 SPS a
main-loop pass must come back within 0.5 ms or frames are replaced unread
(counted as gaps by the frame numbers, never mixed into one sample).
Serial: usb_cdc.data if enabled in boot.py (a second, binary-clean port),
else the console via supervisor.runtime.serial_bytes_available.
"""

import sys
import time

import board as _board
import busio
import digitalio
import keypad
import supervisor

try:
    import usb_cdc
    _data = usb_cdc.data
except (ImportError, AttributeError):
    _data = None

_TICKS_PERIOD = 1 << 29      # supervisor.ticks_ms wraps at 2**29 ms
_TICKS_HALF = _TICKS_PERIOD // 2


def _pin(name):
    return getattr(_board, name) if isinstance(name, str) else name


class Board:
    REG_BAUD = 1000000    # <= 2 fCLK = 1.024 MHz during register access, §8.3.7
    DATA_BAUD = 8000000   # RDATAC reads may run up to 20 MHz (tSCLK 50 ns, §6.6)

    def __init__(self, cfg, root="/"):
        self.root = root if root != "/" else ""
        self.name = "circuitpython-" + sys.platform
        self.spi = busio.SPI(_pin(cfg["pin_sck"]), MOSI=_pin(cfg["pin_mosi"]), MISO=_pin(cfg["pin_miso"]))
        while not self.spi.try_lock():
            pass
        self.baud = self.REG_BAUD
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
        self._was_low = False

    def set_spi_rate(self, hz):
        self.baud = hz
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

    def drdy(self):
        return not self._drdy.value

    def attach_drdy(self, handler):
        self._handler = handler

    def ticks_ms(self):
        return supervisor.ticks_ms()

    def ticks_us(self):
        return (supervisor.ticks_ms() * 1000) & (_TICKS_PERIOD - 1)

    def ticks_diff(self, a, b):
        return ((a - b + _TICKS_HALF) & (_TICKS_PERIOD - 1)) - _TICKS_HALF

    def sleep_us(self, us):
        time.sleep(us / 1e6)

    def sleep_ms(self, ms):
        time.sleep(ms / 1e3)

    def time(self):
        t = time.time()
        return t if t > 1600000000 else None

    def quit_requested(self):
        return False

    def idle(self):
        # Poll for the falling edge: call the handler once per low period.
        low = not self._drdy.value
        if low and not self._was_low and self._handler is not None:
            self._handler(None)
            low = False   # reading the frame released DRDY (§8.5.1.6)
        self._was_low = low

    def serial_read(self):
        if _data is not None:
            n = _data.in_waiting
            return _data.read(n) if n else None
        n = supervisor.runtime.serial_bytes_available
        return sys.stdin.read(n).encode() if n else None

    def serial_write(self, data):
        if _data is not None:
            _data.write(data)
        else:
            sys.stdout.write(data.decode())

    def log(self, text):
        pass
