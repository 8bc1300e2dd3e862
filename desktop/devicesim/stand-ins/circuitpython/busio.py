# Stand-in for CircuitPython's `busio.SPI`, from docs.circuitpython.org shared-bindings/busio:
# SPI(clock, MOSI=None, MISO=None, half_duplex=False) with its lock (try_lock, unlock),
# configure(*, baudrate, polarity, phase, bits), write / readinto / write_readinto with
# start and end slices; its refusals: a pin that is no Pin or is in use, any transfer or
# configure without the lock ("Function requires lock"), slices of different lengths.
# Not a module of the desktop package.
import microcontroller
import simboard

_board = simboard.board()
_MAX = 1 << 30


class SPI:
    def __init__(self, clock, MOSI=None, MISO=None, half_duplex=False):
        pins = [("clock", clock)] + [(n, p) for n, p in (("MOSI", MOSI), ("MISO", MISO)) if p is not None]
        for name, p in pins:
            microcontroller.claim(p, name)
        self._pins = [p for _, p in pins]
        self._locked = False
        self.frequency = 250000
        _board.set_spi(self.frequency, 0, 0)

    def deinit(self):
        for p in self._pins:
            microcontroller.release(p)
        self._pins = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.deinit()

    def try_lock(self):
        if self._locked:
            return False
        self._locked = True
        return True

    def unlock(self):
        self._locked = False

    def _require_lock(self):
        if not self._locked:
            raise RuntimeError("Function requires lock")

    def configure(self, *, baudrate=100000, polarity=0, phase=0, bits=8):
        self._require_lock()
        if polarity not in (0, 1) or phase not in (0, 1):
            raise ValueError("polarity and phase must be 0 or 1")
        if bits not in (8, 16):
            raise ValueError("bits must be 8 or 16")
        self.frequency = baudrate
        _board.set_spi(baudrate, polarity, phase)

    @staticmethod
    def _span(buf, start, end):
        end = len(buf) if end is None or end > len(buf) else end
        if start < 0 or start > end:
            raise ValueError("start/end out of range")
        return start, end

    def write(self, buffer, *, start=0, end=None):
        self._require_lock()
        a, b = self._span(buffer, start, end)
        _board.transfer(memoryview(buffer)[a:b] if a or b != len(buffer) else buffer, None, b - a)

    def readinto(self, buffer, *, start=0, end=None, write_value=0):
        self._require_lock()
        a, b = self._span(buffer, start, end)
        view = memoryview(buffer)[a:b] if a or b != len(buffer) else buffer
        _board.transfer(bytes([write_value]) * (b - a) if write_value else None, view, b - a)

    def write_readinto(self, out_buffer, in_buffer, *, out_start=0, out_end=None, in_start=0, in_end=None):
        self._require_lock()
        a, b = self._span(out_buffer, out_start, out_end)
        c, d = self._span(in_buffer, in_start, in_end)
        if b - a != d - c:
            raise ValueError("buffer slices must be of equal length")
        _board.transfer(memoryview(out_buffer)[a:b], memoryview(in_buffer)[c:d], b - a)
