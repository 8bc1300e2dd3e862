"""A walked survey recorded from the handheld: readings and marks on the board's clock, merged
from the stream, the handheld's flash log and a journal, written as the capture `fluxcal map` reads.

    rec = Recording(grid, nT_per_code, meta)     # or Recording.load(path) to continue a file
    rec.reading(ms, f_nT, codes, temp_c)         # a streamed `data` event (ms since `survey start`)
    rec.mark(ms)                                 # a `mark` event: a line's start or end
    rec.merge_log(raw_bytes)                     # the handheld's survey.bin (device/surveylog.py)
    rec.save(path)                               # SURVEY.npz (desktop/formats/capture.py's keys)

Every reading is keyed by its millisecond on the board's clock (from `survey start`),
so the same block met twice (streamed, journalled, then pulled from the flash) is
one reading: the stream's is kept (it has the codes; the log has |B| to 0.01 nT
only). Marks pair up in time order: the 1st and 2nd a line's start and end, the
3rd and 4th the next line's, and so on; a last unpaired mark is a line begun.

The file (desktop/formats/capture.py, a handheld's recording): t (N,) s since
`survey start`, f_nT (N,) |B| as the handheld computed it (its calibration in force),
codes (N, 3) mean codes of each block (NaN for readings only the flash log had),
die_temperature_c (N,) (NaN likewise), nT_per_code, marks_s (M,), line_marks (L, 2),
config (the grid, the pace, where the readings came from), and with a GPS gps_t,
gps_lat, gps_lon, gps_quality (GGA fixes on the board's clock).
"""

import json
import os
import struct

import numpy as np

from desktop.formats import FormatError
from desktop.formats.capture import load_capture

LOG_MAGIC = b"FXSVLOG1"     # device/surveylog.py's header, its records <uint32 ms, int32 value>
LOG_MARK = -2147483648


def parse_log(raw):
    """([(ms, f_nT)], [mark ms]) from the bytes of a survey.bin; a torn last record is dropped."""
    if not raw:
        return [], []
    if not raw.startswith(LOG_MAGIC):
        raise FormatError("the handheld's survey log does not start with %r: not a survey log" % LOG_MAGIC)
    body = raw[len(LOG_MAGIC):]
    body = body[:len(body) - len(body) % 8]
    readings, marks = [], []
    for ms, value in struct.iter_unpack("<Ii", body):
        if value == LOG_MARK:
            marks.append(ms)
        else:
            readings.append((ms, value / 100.0))
    return readings, marks


def line_count(grid):
    """Lines in a grid as the walk lays them: width / spacing, rounded (desktop/sim/walk.py)."""
    return max(int(round(grid["width_m"] / grid["spacing_m"])), 1)


class Recording:
    def __init__(self, grid, nT_per_code, meta=None):
        self.grid = dict(grid)              # width_m, length_m, spacing_m, zigzag, pace_s_per_m
        self.nT_per_code = [float(v) for v in nT_per_code]
        self.meta = dict(meta or {})
        self.readings = {}                  # ms -> [f_nT, cx, cy, cz, temp_c] (NaN: not known)
        self.marks = set()                  # ms
        self.sources = {"stream": 0, "flash log": 0}
        self.gps = []                       # (t s on the board's clock, lat, lon, quality)

    # ****** what comes in ******
    def reading(self, ms, f_nT, codes=None, temp_c=None):
        c = list(codes) if codes is not None else [np.nan] * 3
        new = int(ms) not in self.readings
        self.readings[int(ms)] = [float(f_nT)] + [float(x) for x in c] + [
            np.nan if temp_c is None else float(temp_c)]
        if new:
            self.sources["stream"] += 1
        return new

    def mark(self, ms):
        new = int(ms) not in self.marks
        self.marks.add(int(ms))
        return new

    def merge_log(self, raw):
        """The flash log's readings and marks that the stream did not bring; how many of each."""
        readings, marks = parse_log(raw)
        got = 0
        for ms, f in readings:
            if ms not in self.readings:
                self.readings[ms] = [f, np.nan, np.nan, np.nan, np.nan]
                self.sources["flash log"] += 1
                got += 1
        new_marks = sum(self.mark(ms) for ms in marks)
        return got, new_marks

    # ****** what it makes ******
    def line_marks(self):
        m = sorted(self.marks)
        return np.array([[m[2 * i], m[2 * i + 1]] for i in range(len(m) // 2)], dtype=float).reshape(-1, 2) / 1000.0

    def lines_done(self):
        return len(self.marks) // 2

    def complete(self):
        return self.lines_done() >= line_count(self.grid)

    def arrays(self):
        ms = np.array(sorted(self.readings), dtype=np.int64)
        rows = np.array([self.readings[k] for k in ms], dtype=float).reshape(-1, 5)
        out = {"t": ms / 1000.0, "f_nT": rows[:, 0], "codes": rows[:, 1:4], "die_temperature_c": rows[:, 4],
               "nT_per_code": np.asarray(self.nT_per_code, dtype=float),
               "marks_s": np.array(sorted(self.marks), dtype=float) / 1000.0, "line_marks": self.line_marks()}
        if self.gps:
            g = np.asarray(self.gps, dtype=float)
            out.update(gps_t=g[:, 0], gps_lat=g[:, 1], gps_lon=g[:, 2], gps_quality=g[:, 3])
        return out

    def config(self):
        survey = dict(self.grid, lines_expected=line_count(self.grid), lines_marked=self.lines_done(),
                      readings_from=dict(self.sources))
        return dict(self.meta, survey=survey, source="fluxcal survey")

    def save(self, path):
        arrays = self.arrays()
        arrays["config"] = np.array(json.dumps(self.config()))
        tmp = path + ".tmp"
        try:
            with open(tmp, "wb") as fh:
                np.savez(fh, **arrays)
            os.replace(tmp, path)       # a file half written never replaces a whole one
        except OSError as exc:
            raise FormatError("%s: %s" % (path, exc.strerror or exc))

    @classmethod
    def load(cls, path):
        """A recording written by save(), to continue (`fluxcal survey --resume / --pull`)."""
        cap = load_capture(path)
        cfg = cap.get("config") or {}
        if cfg.get("source") != "fluxcal survey" or "f_nT" not in cap:
            raise FormatError("%s: not a recording of fluxcal survey (it cannot be continued)" % path)
        grid = {k: v for k, v in cfg["survey"].items()
                if k not in ("lines_expected", "lines_marked", "readings_from")}
        meta = {k: v for k, v in cfg.items() if k not in ("survey", "source")}
        rec = cls(grid, cap["nT_per_code"], meta)
        codes = np.asarray(cap["codes"], dtype=float).reshape(-1, 3)
        for ms, f, c, temp in zip(np.rint(cap["t"] * 1000).astype(int), cap["f_nT"], codes,
                                  cap["die_temperature_c"]):
            rec.readings[int(ms)] = [float(f)] + [float(x) for x in c] + [float(temp)]
        rec.sources = dict(cfg["survey"].get("readings_from", rec.sources))
        for ms in np.rint(np.asarray(cap.get("marks_s", [])) * 1000).astype(int):
            rec.marks.add(int(ms))
        if "gps_t" in cap:
            rec.gps = [tuple(r) for r in np.c_[cap["gps_t"], cap["gps_lat"], cap["gps_lon"], cap["gps_quality"]]]
        return rec
