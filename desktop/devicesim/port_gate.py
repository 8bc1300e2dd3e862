"""The port a client opens, and the emulator's own way to the board while it deploys and starts
its firmware.

    gate = PortGate()                          # gate.port: a pty a client opens as /dev/ttyACM0
    own = gate.hold("deploying its firmware")  # a second pty: the emulator's own line to the board
    ...                                        # a client of gate.port gets an emulator_busy event
    gate.release()                             # the board answers on gate.port again

A board's relay (virtual_board.py, pico_board.py) selects on gate.fds(), hands each ready one
to gate.read(fd) (the bytes for the board, b"" when none) and the board's bytes to
gate.write(data). Why: `fluxcal emulate` prints the port at once, then deploys its firmware
and waits for it to answer; a client that opened the same port meanwhile (fluxcal's exclusive
lock, or its bytes in mpremote's raw REPL) made the emulator's deploy fail, and the whole
virtual handheld exited. Now that client is told, in one protocol line, to try again; its
bytes never reach the board.
"""

import json
import os
import termios
import threading
import tty

from shared import codes

PROTOCOL_VERSION = codes.PROTOCOL_VERSION


def busy_line(doing):
    """The event line a client of a held port gets for each write (desktop/link raises it)."""
    msg = "the emulated board is busy %s; try again in a moment" % doing
    return (json.dumps({"v": PROTOCOL_VERSION, "ev": codes.EV_EMULATOR_BUSY, "msg": msg}) + "\r\n").encode()


class PortGate:
    def __init__(self, drop_when_full=False):
        # drop_when_full: what the board sends while no client reads is dropped rather than
        # stalling the relay (a host that does not read a CDC port loses its bytes)
        self._drop = drop_when_full
        self.master, self.slave = self._pty()
        self.port = os.ttyname(self.slave)
        self._own = None           # (master, slave) of the emulator's own pty, once held
        self.busy = None           # what the board is busy with while held, else None
        self._lock = threading.Lock()

    def _pty(self):
        master, slave = os.openpty()
        tty.setraw(slave)          # a byte pipe: no echo, no newline translation (USB CDC)
        if self._drop:
            os.set_blocking(master, False)
        return master, slave

    def hold(self, doing):
        """Clients of `port` are told the board is busy `doing`; the path of the emulator's own pty."""
        with self._lock:
            if self._own is None:
                self._own = self._pty()
            self.busy = doing
            return os.ttyname(self._own[1])

    def release(self):
        """The board on `port` again; busy lines no client read are flushed."""
        with self._lock:
            self.busy = None
            if self.slave is not None:
                termios.tcflush(self.slave, termios.TCIFLUSH)

    def fds(self):
        """The masters the relay selects on."""
        with self._lock:
            own = [self._own[0]] if self._own is not None and self.busy else []
            return ([self.master] if self.master is not None else []) + own

    def read(self, fd):
        """Bytes from fd for the board: a client's while the port is free, the emulator's own while
        held (a client then gets the busy line instead). b"" when there are none."""
        data = _read(fd)
        with self._lock:
            busy = self.busy
        if fd != self.master:
            return data if busy else b""      # the emulator's own pty, after release: stale
        if busy and data:
            self._send(self.master, busy_line(busy))
            return b""
        return b"" if busy else data

    def write(self, data):
        """What the board sends, to whoever holds the line."""
        with self._lock:
            fd = self._own[0] if self.busy else self.master
        if fd is not None:
            self._send(fd, data)

    def _send(self, fd, data):
        try:
            os.write(fd, data)
        except BlockingIOError:
            pass                   # drop_when_full: no client reads
        except OSError:
            pass                   # closed by close() meanwhile

    def close(self):
        """Close every end: a client reading the port gets an error at once, as when a board is unplugged."""
        with self._lock:
            fds = [self.master, self.slave] + list(self._own or ())
            self.master = self.slave = self._own = None
            self.busy = None
        for fd in fds:
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass


def _read(fd):
    try:
        return os.read(fd, 4096)
    except BlockingIOError:
        return b""
    except OSError:                # EIO: the other end is closed
        return b""
