"""Serial protocol v1: text commands in, JSON lines out (docs/protocol.md).

    proto = Protocol(app, board)
    proto.poll()            # read what arrived, run complete lines, write replies
    proto.event("cal", {...})

Request:  COMMAND [ARGS]\\n     (ASCII; set-cal takes a JSON object as ARGS)
Reply:    {"v": 1, "ok": true, "cmd": "status", ...}\\n
Error:    {"v": 1, "ok": false, "cmd": "x", "error": "unknown_command", "msg": "..."}\\n
Event:    {"v": 1, "ev": "cal" | "data" | "raw" | "boot" | "log", ...}\\n

Nothing from the wire is evaluated: arguments are split on spaces, numbers go
through int()/float(), objects through json.loads, and every handler's
exceptions become an error line. Lines longer than MAX_LINE are discarded up
to their newline and answered with line_too_long; the buffer never grows past
MAX_LINE, so a flood without newlines costs no memory.
"""

import json

VERSION = 1
MAX_LINE = 2048


class ProtocolError(Exception):
    """A request the device refuses: .code is the stable error code."""

    def __init__(self, code, msg):
        super().__init__(msg)  # MicroPython has no Exception.__init__ to call
        self.code = code


def parse_value(text):
    """A config value from the wire: JSON scalar, else a bare word as a string."""
    t = text.strip()
    if t in ("true", "false", "null") or t[:1] in "-0123456789[{\"":
        try:
            return json.loads(t)
        except ValueError:
            raise ProtocolError("bad_value", "cannot parse value %r" % t[:40])
    return t


class Protocol:
    def __init__(self, app, board):
        self.app = app
        self.board = board
        self._buf = bytearray()
        self._overlong = False
        self.errors = 0
        self.commands = {
            "version": app.cmd_version,
            "status": app.cmd_status,
            "get-cal": app.cmd_get_cal,
            "set-cal": app.cmd_set_cal,
            "clear-cal": app.cmd_clear_cal,
            "start-cal": app.cmd_start_cal,
            "finish-cal": app.cmd_finish_cal,
            "cancel-cal": app.cmd_cancel_cal,
            "get-coverage": app.cmd_get_coverage,
            "stream": app.cmd_stream,
            "config": app.cmd_config,
            "help": self.cmd_help,
        }

    def cmd_help(self, args):
        names = list(self.commands)
        names.sort()
        return {"commands": names}

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
        out = {"v": VERSION, "ev": name}
        for k in fields:
            out[k] = fields[k]
        self.send(out)

    # ****** input ******
    def poll(self):
        data = self.board.serial_read()
        if not data:
            return
        for b in data:
            if b == 10:  # \n
                if self._overlong:
                    self._overlong = False
                    self.error("", "line_too_long", "line longer than %d bytes discarded" % MAX_LINE)
                else:
                    line = bytes(self._buf)
                    self._buf = bytearray()
                    self.handle(line)
                continue
            if self._overlong:
                continue
            if len(self._buf) >= MAX_LINE:
                self._overlong = True
                self._buf = bytearray()
                continue
            self._buf.append(b)

    def handle(self, raw):
        try:
            line = raw.decode().strip()
        except UnicodeError:
            self.error("", "bad_encoding", "request is not UTF-8 text")
            return
        if not line:
            return
        for ch in line:
            if ord(ch) < 32 and ch != "\t":
                self.error("", "bad_request", "control character in request")
                return
        sp = line.find(" ")
        cmd = line if sp < 0 else line[:sp]
        args = "" if sp < 0 else line[sp + 1:].strip()
        fn = self.commands.get(cmd)
        if fn is None:
            self.error(cmd[:32], "unknown_command", "unknown command %r; try help" % cmd[:32])
            return
        try:
            self.reply(cmd, fn(args))
        except ProtocolError as e:
            self.error(cmd, e.code, str(e))
        except (ValueError, TypeError, KeyError, IndexError) as e:
            self.error(cmd, "bad_argument", str(e) or e.__class__.__name__)
        except OSError as e:
            self.error(cmd, "io_error", str(e))
        except MemoryError:
            self.error(cmd, "no_memory", "request needs more memory than the device has")
