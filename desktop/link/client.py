"""A fluxcal handheld on a serial port: requests and replies, events kept apart, a deadline on every read.

    dev = Device("/dev/ttyACM0", timeout=2.0)   # opened exclusively; LinkError says why not
    dev.connect()                    # `version`: refuses another protocol version
    dev.ask("get-cal")               # the reply (a dict with "ok": true) or DeviceError
    dev.next_event(1.0)              # the next event, or None after 1 s
    dev.close()

The device answers each request with exactly one line carrying "ok" and the
request's "cmd"; events ("ev") can come before it. Events read while waiting
for a reply are kept, in order, for next_event; a reply to a request this
client did not make (left over from another program) is skipped and counted.
pyserial blocks at most READ_SLICE_S per read, so every wait ends at its
deadline even when the device says nothing at all. An `emulator_busy` event
(`fluxcal emulate` deploying or starting its board's firmware) raises
BusyError at once.
"""

import collections
import errno
import time

import serial

from desktop.link import BusyError, DeviceError, LinkError
from desktop.link.lines import LineReader
from shared.codes import EV_EMULATOR_BUSY
from shared.codes import PROTOCOL_VERSION   # the version this client speaks (docs/protocol.md)

READ_SLICE_S = 0.05    # one pyserial read blocks at most this long; deadlines are checked between reads
MAX_KEPT_EVENTS = 20000


class Device:
    def __init__(self, port, timeout=2.0):
        self.port = port
        self.timeout = timeout
        self.reader = LineReader()
        self.info = None          # the `version` reply, after connect()
        self.stale = 0            # replies to requests this client did not make
        self._events = collections.deque(maxlen=MAX_KEPT_EVENTS)
        self._ready = collections.deque()   # parsed lines not yet looked at
        self.ser = _open(port, timeout)

    def connect(self):
        """Check that fluxcal firmware speaking our protocol answers on the port."""
        # a newline first: ends whatever half request a previous program left in the device's buffer
        self._write(b"\n")
        self.info = self.ask("version")
        proto = self.info.get("proto", self.info.get("v"))
        if proto != PROTOCOL_VERSION:
            raise LinkError("the firmware on %s (fw %s) speaks protocol version %s, this fluxcal version %d: "
                            "install matching firmware (fluxcal deploy) or fluxcal"
                            % (self.port, self.info.get("fw", "?"), proto, PROTOCOL_VERSION))
        return self.info

    def ask(self, command, timeout=None):
        """Send one request line; its reply, or DeviceError when the device refuses it."""
        name = command.split(None, 1)[0]
        self._write(command.encode() + b"\n")
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while True:
            msg = self._next(deadline)
            if msg is None:
                raise LinkError(self._silence("no reply to %r" % name, timeout))
            if "ev" in msg:
                self._events.append(msg)
            elif msg.get("cmd") != name:
                self.stale += 1
            elif msg.get("ok") is True:
                return msg
            else:
                raise DeviceError(name, msg.get("error", "error"), msg.get("msg", ""))

    def next_event(self, timeout):
        """The next event (a dict with "ev"), or None when none came within `timeout` s."""
        if self._events:
            return self._events.popleft()
        deadline = time.monotonic() + timeout
        while True:
            msg = self._next(deadline)
            if msg is None or "ev" in msg:
                return msg
            self.stale += 1

    def close(self):
        try:
            self.ser.close()
        except (serial.SerialException, OSError):
            pass

    # ****** the wire ******
    def _next(self, deadline):
        while not self._ready:
            if time.monotonic() >= deadline:
                return None
            self._ready.extend(self.reader.feed(self._read()))
        msg = self._ready.popleft()
        if msg.get("ev") == EV_EMULATOR_BUSY:   # the emulator, not the firmware, answers: not now
            raise BusyError(str(msg.get("msg") or "the emulated board is busy; try again in a moment"))
        return msg

    def _read(self):
        try:
            return self.ser.read(max(1, self.ser.in_waiting))
        except (serial.SerialException, OSError):
            raise LinkError("lost the device on %s: unplugged, reset or powered off?" % self.port) from None

    def _write(self, data):
        try:
            self.ser.write(data)    # returns once the kernel holds the bytes (no tcdrain: it can wait forever)
        except serial.SerialTimeoutException:
            raise LinkError("the device on %s takes no input (write timed out after %g s)"
                            % (self.port, self.timeout)) from None
        except (serial.SerialException, OSError):
            raise LinkError("lost the device on %s: unplugged, reset or powered off?" % self.port) from None

    def _silence(self, what, timeout):
        """The one line that says a wait ran out, with what came instead."""
        s = "%s from %s within %g s" % (what, self.port, self.timeout if timeout is None else timeout)
        if self.reader.at_repl():
            return s + ": the board answers with its REPL, no fluxcal firmware runs (fluxcal deploy)"
        if not self.reader.skipped:
            return s + ": is the handheld on this port and powered?"
        return s + " (%d lines that were not fluxcal's, the last %r): another device, or noise on the line?" % (
            self.reader.skipped, self.reader.last_junk.decode("ascii", "replace")[:40])


def _open(port, timeout):
    try:
        return serial.Serial(port, baudrate=115200, timeout=READ_SLICE_S, write_timeout=timeout, exclusive=True)
    except serial.SerialException as exc:
        raise LinkError(_open_problem(port, exc)) from None
    except (OSError, ValueError) as exc:
        raise LinkError("cannot open %s: %s" % (port, exc)) from None


def _open_problem(port, exc):
    """One line for a port pyserial could not open. Told apart by errno, which pyserial's
    open() sets from the OSError of opening the device or of its exclusive lock; a file
    that is no terminal fails later, in termios, which pyserial re-raises without one."""
    code = exc.errno
    if code in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EBUSY):   # the lock (flock) or the driver
        return "%s is in use by another program (a terminal, mpremote, Thonny, another fluxcal): close it" % port
    if code == errno.ENOENT:
        return "%s: no such port (fluxcal status without --port lists the boards attached)" % port
    if code == errno.EACCES:
        return "%s: permission denied (on Linux, join the dialout group)" % port
    if _not_a_terminal(exc.__context__):
        return "%s is not a serial port" % port
    return "cannot open %s: %s" % (port, exc)


def _not_a_terminal(cause):
    try:
        import termios   # POSIX; pyserial's Windows back end has no such step
    except ImportError:
        return False
    return isinstance(cause, termios.error)
