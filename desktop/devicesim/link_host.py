"""The host's end of the simulation link: answers the firmware's messages with the World.

The firmware in the `micropython` executable writes sim_wire.py messages to
its stdout (device/sim/sim_link.py); `serve` reads them and calls the World,
which advances simulated time, until the firmware idles at or past the run's
end time. The opcodes are device/sim/sim_wire.py's, imported, never retyped.
"""

import struct

from desktop.firmware.files import import_device

wire = import_device("sim_wire")


class LinkError(RuntimeError):
    """The firmware sent something that is not a message of the wire format."""


class HostLink:
    def __init__(self, world, read, write, on_wait=None):
        self.world = world
        self._read = read           # read(n) -> exactly n bytes (raises when the firmware died)
        self._write = write
        self.on_wait = on_wait      # called whenever the firmware waits (BoardDevice moves serial bytes)
        self.pending = None         # the wait (OP_IDLE, or OP_POLL with its us) the firmware is blocked in
        self.messages = 0

    def _u32(self):
        return struct.unpack("<I", self._read(4))[0]

    def _reply(self):
        w = self.world
        self._write(struct.pack("<IBHB", w.t_us, w.flags, w.pending, 0))

    def _finish_wait(self, wait):
        if self.on_wait is not None:
            self.on_wait()
        op, us = wait
        if op == wire.OP_POLL:
            self.world.poll(us)
        else:
            self.world.idle()
        self._reply()

    def serve(self, until):
        """Answer messages until the firmware waits with the world at `until` s (or quitting)."""
        w = self.world
        w.until = until
        if self.pending is not None:
            if w.time >= until:
                return
            wait, self.pending = self.pending, None
            self._finish_wait(wait)
        read, write = self._read, self._write
        while True:
            op, arg, n = struct.unpack("<BBH", read(wire.HEADER))
            self.messages += 1
            if op == wire.OP_READ:
                write(w.xfer(arg, None, None, n))
            elif op == wire.OP_XFER:
                write(w.xfer(arg, read(n), None, n))
            elif op in (wire.OP_IDLE, wire.OP_POLL):
                wait = (op, self._u32() if op == wire.OP_POLL else 0)
                if self.on_wait is not None:
                    self.on_wait()
                if w.time >= until or w.quit:
                    self.pending = wait     # the run's time is up: the firmware waits here
                    return
                self._finish_wait(wait)
            elif op == wire.OP_STALL_IDLE:
                w.idle(self._u32())
                self._reply()
            elif op == wire.OP_STALL:
                w.stall(self._u32(), arg)
            elif op == wire.OP_SERIAL_READ:
                data = w.serial_read()
                write(struct.pack("<H", len(data)) + data)
            elif op == wire.OP_SERIAL_WRITE:
                w.serial_write(read(n))
            elif op == wire.OP_PIN:
                w.pin(arg, n)
            elif op == wire.OP_SLEEP:
                w.sleep_us(self._u32())
            elif op == wire.OP_BAUD:
                w.set_baud(self._u32())
            else:
                raise LinkError("bad message 0x%02X from the firmware" % op)

    def quit(self):
        """Power off: answer the wait the firmware is blocked in with the quit flag."""
        if self.pending is not None:
            self.world.quit = True
            wait, self.pending = self.pending, None
            self._finish_wait(wait)
