"""Bytes from the device in, protocol lines out (docs/protocol.md, "Framing").

    reader = LineReader()
    for msg in reader.feed(data):    # dicts with "v" and "ok" (a reply) or "ev" (an event)
        ...
    reader.skipped, reader.last_junk

A protocol line is one JSON object with "v" and "ok" or "ev". Anything else on
the wire (a REPL prompt, a boot banner, bytes at the wrong baud rate, a line
cut short by a reset) is skipped and counted, never fatal. A line whose start
was lost may still end in a whole protocol line (a reset mid-line, then the
next line): its longest JSON tail is kept. Bytes without a newline in sight are
dropped once they pass MAX_LINE, so noise cannot grow the buffer.
"""

import json

MAX_LINE = 16384      # longer than any line the firmware writes (a `config get` reply is ~1.5 KB)
_MAX_TAILS = 32       # where a line does not parse, how many '{' to try as its start
REPL_SIGNS = (b">>> ", b"Traceback (most recent call last)", b"MicroPython v", b"Adafruit CircuitPython")


def protocol_line(obj):
    return isinstance(obj, dict) and "v" in obj and ("ok" in obj or "ev" in obj)


class LineReader:
    def __init__(self):
        self._buf = bytearray()
        self.skipped = 0        # lines or pieces of lines that were not protocol lines
        self.last_junk = b""    # the latest of them, for an error message
        self.repl = False       # some looked like a Python REPL's

    def feed(self, data):
        """The protocol lines completed by `data`, in order."""
        self._buf += data
        out = []
        while True:
            end = self._buf.find(b"\n")
            if end < 0:
                break
            line = bytes(self._buf[:end]).strip()
            del self._buf[:end + 1]
            if line:
                msg = self._parse(line)
                if msg is not None:
                    out.append(msg)
        if len(self._buf) > MAX_LINE:
            self._junk(bytes(self._buf[-80:]))
            self._buf.clear()
        return out

    def _parse(self, line):
        msg = _loads(line)
        if protocol_line(msg):
            return msg
        # the line's start may be the remains of a line cut short: try its tails
        start = line.find(b"{", 1)
        for _ in range(_MAX_TAILS):
            if start < 0:
                break
            msg = _loads(line[start:])
            if protocol_line(msg):
                self._junk(line[:start])
                return msg
            start = line.find(b"{", start + 1)
        self._junk(line)
        return None

    def _junk(self, piece):
        self.skipped += 1
        self.last_junk = piece[:80]
        self.repl = self.repl or any(s in piece for s in REPL_SIGNS)

    def at_repl(self):
        """Whether what came looks like a MicroPython/CircuitPython REPL (its prompt waits unterminated)."""
        return self.repl or any(s in self._buf for s in REPL_SIGNS)


def _loads(raw):
    try:
        return json.loads(raw)
    except ValueError:   # not JSON, or not UTF-8
        return None
