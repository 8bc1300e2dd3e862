"""The firmware's end of the simulation link: messages over stdin/stdout.

Used when the firmware runs in the real `micropython` executable; the format
is sim_wire.py, the other end desktop/devicesim/link_host.py. In CPython the
desktop's World object offers the same methods in-process instead.
The SPI path (xfer) runs inside the DRDY handler: it writes from and reads
into preallocated buffers only.
"""

import sys

from sim_wire import (IDLE_REPLY, OP_BAUD, OP_IDLE, OP_PIN, OP_POLL, OP_READ, OP_SERIAL_READ,
                      OP_SERIAL_WRITE, OP_SLEEP, OP_STALL, OP_STALL_IDLE, OP_XFER)

_CHUNK = 4096   # serial writes split below the u16 length field


class PipeLink:
    """Over stdin/stdout by default, or over the given binary files (reader, writer)."""

    def __init__(self, reader=None, writer=None):
        self._r = (reader or sys.stdin.buffer).readinto
        self._w = (writer or sys.stdout.buffer).write
        self._hdr = bytearray(4)
        self._u32 = bytearray(4)
        self._idle = bytearray(IDLE_REPLY)
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

    def _send_u32(self, op, arg, value):
        self._send(op, arg, 4)
        b = self._u32
        b[0] = value & 0xFF
        b[1] = (value >> 8) & 0xFF
        b[2] = (value >> 16) & 0xFF
        b[3] = (value >> 24) & 0xFF
        self._w(b)

    def _read(self, buf, n):
        got = self._r(buf) if n == len(buf) else self._r(memoryview(buf)[:n])
        while got < n:  # a pipe may split a reply: rare, and allocates (never in the ISR tests)
            k = self._r(memoryview(buf)[got:n])
            if not k:
                raise OSError("simulator link closed")
            got += k

    def xfer(self, chip, wbuf, rbuf, n):
        if wbuf is None:
            self._send(OP_READ, chip, n)
        else:
            self._send(OP_XFER, chip, n)
            self._w(wbuf if n == len(wbuf) else memoryview(wbuf)[:n])
        if rbuf is None:
            rbuf = self._zero if n <= len(self._zero) else bytearray(n)
        self._read(rbuf, n)

    def idle(self, max_us=0):
        if max_us:
            self._send_u32(OP_STALL_IDLE, 0, max_us)
        else:
            self._send(OP_IDLE, 0, 0)
        self._reply()

    def poll(self, max_us):
        """A pin read that takes time: see sim_wire.OP_POLL."""
        self._send_u32(OP_POLL, 0, max_us)
        self._reply()

    def _reply(self):
        b = self._idle
        self._read(b, IDLE_REPLY)
        self.t_us = b[0] | (b[1] << 8) | (b[2] << 16) | ((b[3] & 0x3F) << 24)
        self.flags = b[4]
        self.pending = b[5] | (b[6] << 8)

    def serial_read(self):
        self._send(OP_SERIAL_READ, 0, 0)
        self._read(self._len, 2)
        n = self._len[0] | (self._len[1] << 8)
        if not n:
            return b""
        buf = bytearray(n)
        self._read(buf, n)
        return bytes(buf)

    def serial_write(self, data):
        for i in range(0, len(data), _CHUNK):
            part = data[i:i + _CHUNK]
            self._send(OP_SERIAL_WRITE, 0, len(part))
            self._w(part)

    def pin(self, which, value):
        self._send(OP_PIN, which, value)

    def sleep_us(self, us):
        self._send_u32(OP_SLEEP, 0, us)

    def stall(self, us, advance):
        self._send_u32(OP_STALL, 1 if advance else 0, us)

    def set_baud(self, hz):
        self._send_u32(OP_BAUD, 0, hz)
