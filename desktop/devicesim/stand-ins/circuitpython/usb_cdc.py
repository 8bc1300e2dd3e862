# Stand-in for CircuitPython's `usb_cdc` module, from docs.circuitpython.org shared-bindings/usb_cdc:
# enable(*, console=True, data=False) may only be called in boot.py; usb_cdc.data is a Serial
# (in_waiting, read, readinto, write, reset_input_buffer) when boot.py enabled it, else None. Both ports
# are the process's stdin/stdout here. Not a module of the desktop package.
# The receive FIFO is TinyUSB's CFG_TUD_CDC_RX_BUFSIZE, 64 bytes on a full-speed device (CircuitPython's
# supervisor/shared/usb/tusb_config.h leaves the default): in_waiting is at most that, and the host
# refills it as it is read.
import select
import sys

import simboard

_board = simboard.board()
console = None
data = None
RX_FIFO = 64


class Serial:
    def __init__(self):
        self._poll = select.poll()
        self._poll.register(sys.stdin, select.POLLIN)
        self._rx = bytearray()     # arrived, not yet read
        self.timeout = 1.0

    def _fill(self):
        while len(self._rx) < RX_FIFO and self._poll.poll(0):
            self._rx += sys.stdin.buffer.read(1)

    @property
    def in_waiting(self):
        self._fill()
        return len(self._rx)

    def read(self, size=1):
        self._fill()
        out = bytes(self._rx[:size])
        self._rx = self._rx[size:]
        return out

    def readinto(self, buf):
        self._fill()
        n = min(len(buf), len(self._rx))
        buf[:n] = self._rx[:n]
        self._rx = self._rx[n:]
        return n

    def write(self, buf):
        sys.stdout.buffer.write(buf)
        return len(buf)

    def reset_input_buffer(self):
        self._fill()
        self._rx = bytearray()


def enable(*, console=True, data=False):
    if _board.phase != "boot":
        raise RuntimeError("Cannot change USB devices now")
    globals()["console"] = Serial() if console else None
    globals()["data"] = Serial() if data else None
