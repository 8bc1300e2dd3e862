"""Serial protocol v1: text commands in, JSON lines out (docs/protocol.md).

    proto = Protocol(board, commands.TABLE, app)
    proto.poll()            # read what arrived, run complete lines, write replies
    proto.event("cal", {...})

Request:  COMMAND [ARGS]\\n     (ASCII; set-cal takes a JSON object as ARGS)
Reply:    {"v": 1, "ok": true, "cmd": "status", ...}\\n
Error:    {"v": 1, "ok": false, "cmd": "x", "error": codes.UNKNOWN_COMMAND, "msg": "..."}\\n
Event:    {"v": 1, "ev": "cal" | "data" | "raw" | "boot" | "log", ...}\\n

This module only frames lines and writes replies; the commands and their table
are commands.py. Nothing from the wire is evaluated. Every handler's exception
becomes one error line: ProtocolError its own code, ValueError bad_argument,
OSError io_error, MemoryError no_memory, anything else internal_error (a
firmware bug, named, and the device keeps running). Lines longer than MAX_LINE
are discarded up to their newline and answered with line_too_long; the buffer
never grows past MAX_LINE, so a flood without newlines costs no memory.
"""

import json

from shared import codes

VERSION = codes.PROTOCOL_VERSION
MAX_LINE = codes.MAX_LINE   # request bytes before the newline


def json_number(x, nd=3):
    """x rounded to nd decimals for a JSON line; None for None, NaN or inf (JSON has no NaN)."""
    if x is None or x != x or x in (float("inf"), float("-inf")):
        return None
    return round(x, nd)


# the survey's per-block event lines (device/survey.py), each one bytes format of the whole line,
# written out (not joined at import: the heap): the protocol version first, then the raw
# event's or the data event's members; the temperature as bytes ("%.2f" of it, or null when it
# is not a number), the mean codes in hundredths, the data event's h_c and |h_c| in thousandths;
# each of those numbers three parts of parts3() (|h_c| two: never negative). Bytes, and one
# format a block: each str made costs ~15 k cycles on an RP2040 (MicroPython looks it up among
# the interned ones), a bytes ~1.5 k, and the line goes to the serial port as it is
# (Protocol.send_line), no head, join or encode. fitsums.line (device/native/line.h) writes the
# same line from the numbers themselves into a buffer the survey owns, nothing allocated.
RAW_LINE = b'{"v": %d, "ev": "raw", "t": %d, "n": %d, "c": [%s%d.%02d, %s%d.%02d, %s%d.%02d], "temp": %s}\n'
DATA_LINE = (b'{"v": %d, "ev": "data", "t": %d, "temp": %s, "c": [%s%d.%02d, %s%d.%02d, %s%d.%02d], "cal": %s, '
             b'"warn": %s, "b": [%s%d.%03d, %s%d.%03d, %s%d.%03d], "f": %d.%03d}\n')


def parts3(a, b, c, p):
    """The nine parts (sign, whole, fraction: a b'%s%d.%0Nd' each, the sign bytes) of the ints a, b,
    c of 1/p units."""
    sa = sb = sc = b""
    if a < 0:
        sa = b"-"
        a = -a
    if b < 0:
        sb = b"-"
        b = -b
    if c < 0:
        sc = b"-"
        c = -c
    return (sa, a // p, a % p, sb, b // p, b % p, sc, c // p, c % p)


def hundredths(s, d):
    """s / d in hundredths, rounded half up, in small ints (|s| < 2**30, d < 2**21): 200 s would
    be a big integer on a 32-bit port, a heap allocation an operation."""
    q = s // d
    return 100 * q + (200 * (s - q * d) + d) // (2 * d)


class ProtocolError(Exception):
    """A request the device refuses: .code is the stable error code."""

    def __init__(self, code, msg):
        super().__init__(msg)  # MicroPython has no Exception.__init__ to call
        self.code = code


class Protocol:
    """Line framing and replies; the commands are a table of handler(context, args) -> dict."""

    def __init__(self, board, commands, context):
        self.board = board
        self.commands = commands   # name -> handler(context, args), commands.py's TABLE
        self.context = context     # what the handlers act on (the App)
        self._buf = bytearray()
        self._overlong = False
        self.heard = False         # bytes came at the last poll
        self.errors = 0

    # ****** output ******
    def send(self, obj):
        self.board.serial_write((json.dumps(obj) + "\n").encode())

    def reply(self, cmd, fields):
        out = {"v": VERSION, "ok": True, "cmd": cmd}
        if fields:
            for k in fields:
                out[k] = fields[k]
        self.send(out)

    def error(self, cmd, code, msg):
        self.errors += 1
        self.send({"v": VERSION, "ok": False, "cmd": cmd, "error": code, "msg": msg})

    def event(self, name, fields):
        """An event line: fields a dict of its members."""
        out = {"v": VERSION, "ev": name}
        for k in fields:
            out[k] = fields[k]
        self.send(out)

    def send_line(self, line):
        """An event line made whole (newline ended): survey.py's per-block events (RAW_LINE,
        DATA_LINE), 10 a second, printed from integers to digits a narrow float cannot hold; bytes,
        or a view of the survey's buffer, valid during the call only (the next block writes over it)."""
        self.board.serial_write(line)

    # ****** input ******
    def poll(self):
        """Frame what arrived (bytes or bytearray) into lines, run them.

        By slices and find(), not byte by byte: a flood without newlines (a file sent to the
        wrong port) is discarded at the speed of one C search per read, so a request behind
        it is answered within seconds, not minutes (docs/protocol.md, Framing)."""
        data = self.board.serial_read()
        self.heard = data is not None     # bytes came: the main loop's next pass is a short one (app.py)
        if data:
            self._frame(data)     # a method of its own: this frame stays off the heap (app.py, Frames)

    def _frame(self, data):
        start, end = 0, len(data)
        while start < end:
            nl = data.find(b"\n", start)
            stop = end if nl < 0 else nl
            if not self._overlong:
                if len(self._buf) + stop - start > MAX_LINE:
                    self._overlong = True      # the rest of this line is dropped, up to its newline
                    self._buf = bytearray()
                else:
                    self._buf.extend(memoryview(data)[start:stop])
            if nl < 0:
                return
            start = nl + 1
            if self._overlong:
                self._overlong = False
                self.error("", codes.LINE_TOO_LONG, "line longer than %d bytes discarded" % MAX_LINE)
            else:
                line = bytes(self._buf)
                self._buf = bytearray()
                self.handle(line)

    def handle(self, raw):
        # Requests are ASCII (docs/protocol.md; JSON escapes anything else). Checked byte by
        # byte: MicroPython's decode() passes overlong UTF-8 and surrogates, which would
        # then be echoed raw into a reply that is no longer UTF-8.
        raw = raw.strip()   # ASCII white space, \r of \r\n included
        if not raw:
            return
        for b in raw:
            if b > 126:
                self.error("", codes.BAD_ENCODING, "request is not ASCII text")
                return
            if b < 32 and b != 9:
                self.error("", codes.BAD_REQUEST, "control character in request")
                return
        line = raw.decode()
        sp = line.find(" ")
        cmd = line if sp < 0 else line[:sp]
        args = "" if sp < 0 else line[sp + 1:].strip()
        fn = self.commands.get(cmd)
        if fn is None:
            self.error(cmd[:32], codes.UNKNOWN_COMMAND, "unknown command %r; try help" % cmd[:32])
            return
        try:
            self.reply(cmd, fn(self.context, args))
        except ProtocolError as e:
            self.error(cmd, e.code, str(e))
        except ValueError as e:   # a value the handler's parsing or validation refused
            self.error(cmd, codes.BAD_ARGUMENT, str(e) or "bad argument")
        except OSError as e:
            self.error(cmd, codes.IO_ERROR, str(e))
        except MemoryError:
            self.error(cmd, codes.NO_MEMORY, "request needs more memory than the device has")
        except Exception as e:  # noqa: BLE001 - a firmware bug: say so, keep serving
            self.error(cmd, codes.INTERNAL_ERROR, "%s: %s" % (e.__class__.__name__, e))
