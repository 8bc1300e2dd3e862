"""Survey recording on the handheld: the button's line marks and an append-only log on the flash.

    rec = Recorder(board, proto, root, button, most)   # `survey start` (commands.py): imported only then
    rec.block(t, f)      # every output block while recording (survey.Output): |B| to the log
    rec.press(ev)        # the button while recording (app.py): a short press is a line mark
    rec.stop()           # `survey stop`: the log stays on the flash for a pull
    read_chunk(root, offset)   # `survey read OFFSET`: the log's bytes, hex, for the laptop
    command(app, args)   # the `survey` command (commands.py hands it over on its first use)

The laptop records the streamed |B| (`fluxcal survey`); the log is what a lost
connection cannot take: `fluxcal survey --resume` or `--pull` completes the file from it.

survey.bin: an 8-byte header (MAGIC), then 8-byte records, little-endian
<uint32 ms since `survey start`, int32 value>: |B| in hundredths of a nT (48,000 nT
is 4,800,000; 0.01 nT is below the fluxgate's noise), or MARK for a button mark.
Appended and flushed every FLUSH_EVERY records and at every mark: a power cut
loses at most a second of |B| and no mark; a record cut short by it is dropped
when read (the file's length is cut to whole records).

Bounded: LOG_BYTES (27 min of 10 Hz blocks) or what `survey start MAX_BYTES` asks,
less when the flash has less free beyond RESERVE_BYTES. When full the log stops and keeps what it has (the
survey's start is never overwritten: the laptop still gets the stream); the
`survey` reply and one `survey` event say so.
"""

import os
import struct

from button import SHORT
from protocol import ProtocolError
from shared import codes
from store import file_path, free_bytes

NAME = "survey.bin"
MAGIC = b"FXSVLOG1"
RECORD = 8
MARK = -2147483648          # int32 minimum: a mark, never a |B|
LOG_BYTES = 131072          # 16,383 records: 27 min at 10 Hz
RESERVE_BYTES = 65536       # the flash keeps this much free (the calibration's files)
FLUSH_EVERY = 10            # records between flushes: a second at 10 Hz
CHUNK = 256                 # bytes a `survey read` returns (512 hex digits, well within a line)


class Recorder:
    def __init__(self, board, proto, root, button, most=LOG_BYTES):
        self.board = board
        self.proto = proto
        self.button = button
        self.path = file_path(root, NAME)
        self.t0 = board.ticks_ms()
        self.records = 0
        self.marks = 0
        self.full = False
        self.error = None
        self._buf = bytearray(RECORD)
        self._unflushed = 0
        try:
            os.remove(self.path)
        except OSError:
            pass
        free = free_bytes(root)
        self.limit = most if free is None else min(most, max(0, free - RESERVE_BYTES))
        self.f = open(self.path, "wb")    # an OSError here refuses `survey start` (io_error)
        self.f.write(MAGIC)
        self.f.flush()
        self.size = len(MAGIC)

    def _append(self, ms, value):
        if self.f is None:
            return
        if self.size + RECORD > self.limit:
            self.full = True
            self.flush(close=True)
            self.proto.event("survey", {"state": "log_full", "bytes": self.size, "records": self.records})
            return
        struct.pack_into("<Ii", self._buf, 0, ms & 0xFFFFFFFF, value)
        try:
            self.f.write(self._buf)
            self.size += RECORD
            self._unflushed += 1
            if value == MARK or self._unflushed >= FLUSH_EVERY:
                self.f.flush()
                self._unflushed = 0
        except OSError as e:
            self.error = "log_error: %s" % e
            self.flush(close=True)

    def block(self, t, f):
        """An output block (its ticks_ms, its mean |B| in milli-nT: an int, survey.py's) while
        recording; kept in hundredths of a nT, rounded in integers."""
        self.records += 1
        self._append(self.board.ticks_diff(t, self.t0), (f + 5) // 10)

    def press(self, ev):
        """A short press marks a line's start or end (at the press, not the release); a long one
        is ignored while recording (a thumb resting on the button must not end the survey)."""
        if ev != SHORT:
            return
        down = self.button.pressed_at
        ms = self.board.ticks_diff(down, self.t0)
        self.marks += 1
        self._append(ms, MARK)
        self.proto.event("mark", {"t": down, "ms": ms, "n": self.marks})

    def flush(self, close=False):
        """What is written onto the flash (a power cut keeps it); close: and the log ends."""
        f = self.f
        if close:
            self.f = None
        try:
            if f is not None:
                f.close() if close else f.flush()
        except OSError:
            pass

    def stop(self):
        self.flush(close=True)

    def status(self):
        return {"recording": self.f is not None, "t0": self.t0, "records": self.records, "marks": self.marks,
                "bytes": self.size, "limit": self.limit, "full": self.full, "error": self.error}


def read_chunk(root, offset):
    """{offset, size, data (hex)} of the log from `offset`: CHUNK bytes at most."""
    path = file_path(root, NAME)
    try:
        size = os.stat(path)[6]
    except OSError:
        return {"offset": offset, "size": 0, "data": ""}
    with open(path, "rb") as f:
        f.seek(offset)
        data = f.read(CHUNK)
    return {"offset": offset, "size": size, "data": "".join("%02x" % b for b in data)}


def command(app, args):
    """survey start [MAX_BYTES] | stop | info | read OFFSET (docs/protocol.md)."""
    words = args.split()
    what = words[0] if words else "info"
    rec = app.recorder
    out = app.output
    if what == "start" and (len(words) == 1 or len(words) == 2 and words[1].isdigit()):
        if app.flow.session is not None or rec is not None:
            raise ProtocolError(codes.BUSY, "calibration in progress; cancel-cal first" if rec is None
                                else "survey recording; survey stop first")
        rec = Recorder(app.board, app.proto, app.board.root, app.button, int(words[1]) if len(words) == 2
                       else LOG_BYTES)
        app.recorder = out.recorder = rec
        out.set_stream(out.stream)      # |B| per block from now, streamed or not
        return rec.status()
    if what == "stop" and len(words) == 1:
        if rec is None:
            raise ProtocolError(codes.BAD_ARGUMENT, "no survey is recording")
        rec.stop()
        app.recorder = out.recorder = None
        out.set_stream(out.stream)
        return rec.status()
    if what == "info" and len(words) == 1:
        return rec.status() if rec is not None else {"recording": False}
    if what == "read" and len(words) == 2 and words[1].isdigit():
        if rec is not None:
            rec.flush()
        return read_chunk(app.board.root, int(words[1]))
    raise ProtocolError(codes.BAD_ARGUMENT, "survey takes: start [MAX_BYTES] | stop | info | read OFFSET")
