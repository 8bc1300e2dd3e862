"""Fuzz the firmware's command parser on the real `micropython` over a pseudo-terminal.

    python -m desktop.bench.fuzz --cases 20000             # prints a tally, then every failure
    python -m desktop.bench.fuzz --cases 500 --seed 7 --kind micropython-float32

A case is a burst of bytes for the serial line: a command from the firmware's table
(device/commands.py) with generated arguments, a set-cal record mutated field by field,
a `config set` of a key of device/config.py's SCHEMA to a generated value, random
bytes (NUL, Ctrl-C, invalid UTF-8), lines at and past the 2048-byte limit, floods.
After each case the harness sends `version` and checks (docs/protocol.md):

- every request line got exactly one reply line ({"v": 1, "ok": ...}, an `error` code
  and a `msg` when ok is false; no `internal_error`, which the protocol calls a
  firmware bug), and nothing on the line was anything but JSON;
- the firmware kept running (the `version` after the case answers);
- after a set-cal it accepted, the survey streams: `stream corrected` gives data events
  for a few blocks, their numbers finite or null.

Then it restores what the case changed (calibration session cancelled, config keys back
to their defaults, stream off), so cases do not pile up state; a set calibration stays,
as it would on a device. A firmware that dies is restarted on a fresh flash (a bricking
record would kill every boot) and the case is a failure with its exact input.

The grammar is written against a small `draw` interface (pick, int, real, raw, chance),
so tests/test_protocol_fuzz.py drives the same cases from hypothesis (bounded, shrunk to
a minimal failing input) and this script from random.Random (long runs, tallied).
Not a benchmark: the tally is the output.
"""

import argparse
import collections
import json
import math
import os
import random
import signal
import sys
import tempfile
import time

import serial

from desktop.devicesim.client import Client
from desktop.devicesim.runners import DeviceDied, start_device
from desktop.devicesim.world import make_world
from desktop.firmware.files import import_device

_commands = import_device("commands")
_config = import_device("config")
MAX_LINE = import_device("protocol").MAX_LINE
SCHEMA = _config.SCHEMA
# `repl` hands the line to the REPL and ends main.py: a case of its own (tests/test_device_repl.py)
COMMANDS = sorted(c for c in _commands.TABLE if c != "repl")
K = SCHEMA["scale_x"][0]          # nT per code of the default front end
SECONDS = 60.0                    # simulated seconds per device; restarted before they run out
PER_PASS = 512                    # bytes of a burst the firmware gets per main-loop pass (Harness._write)


# ****** values that JSON cannot carry, written as raw text ******
class Raw:
    """Text put into a JSON document as it is: NaN, Infinity, 1e309, a 400-digit integer."""

    def __init__(self, text):
        self.text = text

    def __repr__(self):
        return "Raw(%r)" % (self.text if len(self.text) < 40 else self.text[:37] + "...")


def dumps(v):
    """JSON text of v; Raw pieces verbatim (so the text may be anything but JSON)."""
    if isinstance(v, Raw):
        return v.text
    if v is None or isinstance(v, (bool, str)):
        return json.dumps(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else {"inf": "Infinity", "-inf": "-Infinity"}.get(repr(v), "NaN")
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(dumps(x) for x in v) + "]"
    return "{" + ", ".join(json.dumps(str(k)) + ": " + dumps(x) for k, x in v.items()) + "}"


SPECIAL_NUMBERS = [Raw("NaN"), Raw("Infinity"), Raw("-Infinity"), Raw("1e309"), Raw("-1e309"), Raw("nan"),
                   Raw("inf"), Raw(str(10 ** 400)), Raw("-" + str(10 ** 400)), Raw("1e-400"), Raw("-0"),
                   Raw("0x10"), Raw("1_000"), Raw("01"), Raw("+1"), Raw(".5"), Raw("1."), Raw("1e"),
                   1e308, -1e308, 1e-3, 1e-300, 5e-324, 1e12, -1e12, 8388609.0, 2 ** 31, 2 ** 63, -2 ** 63,
                   0, 0.0, -0.0, 1, -1, 10 ** 30]
WRONG_TYPES = ["12", "hot", "", "\u00e9\u00e8", "\\u0000", True, False, None, [], {}, [1, 2], [1, 2, 3, 4],
               [[1, 0, 0], [0, 1, 0]], {"a": {"b": [1, {"c": "d"}]}}, ["x", "y", "z"], [None, None, None]]
NASTY_BYTES = [b"\x00", b"\x03", b"\x04", b"\x1b[A", b"\xc3\x28", b"\xff\xfe", b"\xed\xa0\x80",
               b"\xf4\x90\x80\x80", b"\xc0\xaf", b"\xe2\x80\xa8", b"\xc2\x85", b"\xe3\x80\x80", b"\r",
               b"\r\r", b"\t", b"\x0b\x0c", b"\x7f", b"\xef\xbb\xbf", b" ", b"\\", b'"', b"{", b"}"]
WORDS = ["on", "off", "quick", "full", "auto", "raw", "corrected", "get", "set", "sideways", "true", "false", "null", "help", "-",
         "__import__('os')", "../../cal.json", "%s%s%n", "\u00fc\u00f1\u00ee", "a" * 40, "STATUS", "0"]


def deep(r):
    n = r.int(50, 1000)
    return Raw(r.pick(["[" * n + "]" * n, '{"a": ' * n + "1" + "}" * n, "[" * n, '{"a": [' * (n // 2)]))


def json_value(r, depth=0):
    """Any JSON value, and some that are not JSON."""
    kind = r.pick(["special", "wrong", "int", "real", "text", "list", "object", "deep"] if depth < 3
                  else ["special", "wrong", "int", "real", "text"])
    if kind == "special":
        return r.pick(SPECIAL_NUMBERS)
    if kind == "wrong":
        return r.pick(WRONG_TYPES)
    if kind == "int":
        return r.pick([r.int(-10, 10), r.int(-2 ** 40, 2 ** 40), 10 ** r.int(15, 400)])
    if kind == "real":
        return r.real(-1e6, 1e6) * 10 ** r.int(-20, 20)
    if kind == "text":
        return r.pick(WORDS) * r.int(1, 3)
    if kind == "list":
        return [json_value(r, depth + 1) for _ in range(r.int(0, 4))]
    if kind == "object":
        return {r.pick(WORDS): json_value(r, depth + 1) for _ in range(r.int(0, 4))}
    return deep(r)


# ****** set-cal records ******
def good_record(r):
    """A calibration the firmware accepts on its default config: gains within 25 % of the
    front end's, a small axis skew, offsets and a field a sensor has."""
    g = [r.real(0.8, 1.2) for _ in range(3)]
    s = K * r.real(-0.03, 0.03)
    return {"version": 1,
            "matrix": [[K * g[0], s, 0.0], [s, K * g[1], 0.0], [0.0, 0.0, K * g[2]]],
            "offset": [r.real(-5000.0, 5000.0) for _ in range(3)],
            "field": r.real(30000.0, 60000.0),
            "diagnostics": {"n": r.int(20, 3000), "rms": r.real(0.0, 2.0), "observability": r.real(0.1, 1.0),
                            "predicted_error": r.real(0.0, 2.0), "iterations": r.int(1, 30)},
            "meta": {"temperature_c": r.real(-20.0, 60.0), "firmware": "0.1.0", "uptime_ms": r.int(0, 10 ** 7),
                     "rate": 1000, "scale": [K, K, K]}}


def skewed_matrix(r):
    """An axis tilted by up to 89.9 degrees, a reversed or swapped axis, a gain off by 10."""
    t = math.radians(r.real(0.0, 89.9))
    s, c = math.sin(t), math.cos(t)
    return r.pick([
        [[K, K * s, 0.0], [K * s, K, 0.0], [0.0, 0.0, K]],           # symmetric, cond (1+s)/(1-s)
        [[K, 0.0, 0.0], [K * s, K * c, 0.0], [0.0, 0.0, K]],         # y tilted toward x
        [[-K, 0.0, 0.0], [0.0, K, 0.0], [0.0, 0.0, K]],              # x reversed
        [[0.0, K, 0.0], [K, 0.0, 0.0], [0.0, 0.0, K]],               # x and y swapped
        [[10 * K, 0.0, 0.0], [0.0, K, 0.0], [0.0, 0.0, K]],
        [[K, 1.0, 0.0], [1.0, K, 0.0], [0.0, 0.0, K]],
        [[0.0] * 3] * 3,
    ])


def _mutate(r, rec):
    where = r.pick(["matrix", "matrix", "offset", "offset", "field", "field", "version", "diagnostics",
                    "meta", "meta.temperature_c", "meta.temperature_c", "meta.*", "meta.*", "diagnostics.*",
                    "top.*", "delete"])
    value = r.pick([json_value, json_value, lambda r: r.pick(SPECIAL_NUMBERS), lambda r: r.pick(WRONG_TYPES)])(r)
    if where == "matrix":
        i, j = r.int(0, 2), r.int(0, 2)
        m = rec.get("matrix")
        same = [list(row) if isinstance(row, list) else row for row in m] if isinstance(m, list) else m
        rec["matrix"] = r.pick([skewed_matrix(r), value, same])
        if isinstance(rec["matrix"], list) and len(rec["matrix"]) == 3 and isinstance(rec["matrix"][i], list):
            rec["matrix"][i] = list(rec["matrix"][i])
            if r.chance(0.5):
                rec["matrix"][i][j] = value
    elif where == "offset":
        rec["offset"] = r.pick([value, [value, 0.0, 0.0], [0.0, 0.0, r.pick([1e12, -1e12, 8388608.5, value])]])
    elif where == "field":
        rec["field"] = r.pick([value, 1e-3, 1e308, 999.0, 100001.0, r.real(1000.0, 100000.0)])
    elif where in ("version", "diagnostics", "meta"):
        rec[where] = value
    elif where == "delete":
        rec.pop(r.pick(sorted(rec)), None)
    else:
        group, key = where.split(".")
        if key == "*":
            key = r.pick({"meta": ["firmware", "uptime_ms", "time", "rate", "scale", "source", "units", "n", "x"],
                          "diagnostics": ["n", "rms", "observability", "predicted_error", "iterations",
                                          "coverage", "radius", "rejected", "x"],
                          "top": ["x", "cal", "matrix ", "MATRIX"]}[group])
        target = rec if group == "top" else rec.get(group)
        if not isinstance(target, dict):
            target = rec[group] = {}
        target[key] = value


def set_cal_line(r):
    rec = good_record(r)
    for _ in range(r.pick([0, 1, 1, 1, 2, 3])):
        _mutate(r, rec)
    return "set-cal " + dumps(rec)


# ****** config ******
def config_value(r, key):
    default, kind, lo, hi = SCHEMA.get(key, (0, "int", 0, 1))
    valid = [default]
    if kind in ("int", "float", "opt_float"):
        valid += [lo, hi, r.real(lo, hi), lo - 1, hi + 1, hi * 10, -hi]
        if kind == "int":
            valid += [r.int(int(lo), int(hi)), float(r.int(int(lo), int(hi))), r.int(int(lo), int(hi)) + 0.5]
        if kind == "opt_float":
            valid.append(None)
    elif kind == "bool":
        valid += [True, False, 0, 1, "yes"]
    elif kind == "pin":
        valid += [r.int(0, 40), "GP%d" % r.int(0, 40), -1, 1.5]
    elif kind.startswith("choice:"):
        valid += kind[7:].split("|") + ["ON", "raw corrected"]
    v = r.pick([r.pick(valid), r.pick(valid), r.pick(SPECIAL_NUMBERS), json_value(r)])
    if isinstance(v, str) and r.chance(0.5):
        return v                 # a bare word
    return dumps(v)


def config_line(r):
    key = r.pick(sorted(SCHEMA) * 3 + WORDS)
    form = r.pick(["set", "set", "set", "set", "get", "get-all", "bare", "extra"])
    if form == "set":
        return "config set %s %s" % (key, config_value(r, key))
    if form == "get":
        return "config get " + key
    if form == "get-all":
        return "config get"
    if form == "bare":
        return r.pick(["config", "config set", "config set " + key, "config frob " + key])
    return "config set %s %s %s" % (key, config_value(r, key), config_value(r, key))


# ****** other commands, bytes, long lines, floods ******
def command_line(r):
    cmd = r.pick(COMMANDS)
    if cmd == "stream":
        return "stream " + " ".join(r.pick(WORDS) for _ in range(r.int(0, 3)))
    args = r.pick(["", "", "", " " + r.pick(WORDS), " " + dumps(json_value(r))])
    pad = r.pick(["", "", " ", "\t", "  ", "\r"])
    return pad + cmd + args + pad


def noise(r):
    """Bytes of any kind, newlines included."""
    parts = [r.raw(64) for _ in range(r.int(0, 2))] + [r.pick(NASTY_BYTES) for _ in range(r.int(0, 4))]
    parts.append(r.pick([b"", b"status", b"version", b"set-cal {", b"config set rate "]))
    out = b"".join(parts[i] for i in r.order(len(parts)))
    return out


def long_line(r):
    """At and around the 2048-byte limit, and far past it (with and without a newline)."""
    n = r.pick([MAX_LINE - 2, MAX_LINE - 1, MAX_LINE, MAX_LINE + 1, MAX_LINE + 2, r.int(2 * MAX_LINE, 6 * MAX_LINE)])
    head = r.pick([b"status ", b"set-cal {\"a\": \"", b"config set field_nt ", b"", b"\xff"])
    fill = r.pick([b"x", b" ", b"9", b"\x00", b"[", b"\xc3\xa9"])
    return (head + fill * n)[:n]


def flood(r, most):
    line = r.pick([b"version", b"nope", b"get-cal", b"help", b"\xff", b"config get rate", b"stream off", b""])
    n = r.int(2, most)
    if r.chance(0.2):   # no newline at all until the end
        return r.pick([b"y", b"\x00", b"{"]) * (n * 100)
    return b"\n".join([line] * n)


GRAMMAR = ("command", "set-cal", "config", "bytes", "long", "flood", "mixed")


def case(r, kind=None, flood_max=200):
    """One case: the bytes sent in one burst (the harness adds a newline and `version`)."""
    kind = kind or r.pick(GRAMMAR)
    if kind == "command":
        return command_line(r).encode()
    if kind == "set-cal":
        return set_cal_line(r).encode()
    if kind == "config":
        return config_line(r).encode()
    if kind == "bytes":
        return noise(r)
    if kind == "long":
        return long_line(r)
    if kind == "flood":
        return flood(r, flood_max)
    parts = [case(r, r.pick(GRAMMAR[:-2]), flood_max) for _ in range(r.int(2, 4))]
    return b"".join(p + r.pick([b"\n", b"\n", b"", b"\r\n"]) for p in parts)


class RandomDraw:
    """The grammar's draw interface over random.Random."""

    def __init__(self, seed):
        self.r = random.Random(seed)

    def pick(self, seq):
        return seq[self.r.randrange(len(seq))]

    def int(self, lo, hi):
        return self.r.randint(lo, hi)

    def real(self, lo, hi):
        return self.r.uniform(lo, hi)

    def chance(self, p):
        return self.r.random() < p

    def raw(self, most):
        return bytes(self.r.getrandbits(8) for _ in range(self.r.randint(0, most)))

    def order(self, n):
        idx = list(range(n))
        self.r.shuffle(idx)
        return idx


# ****** what the firmware must answer ******
def expected_replies(data, kind="micropython"):
    """Replies the protocol owes for `data` (docs/protocol.md): one per line, none for a
    blank one (white space only: ASCII white space on MicroPython, whose str.strip knows
    no other; Unicode's on CPython), one for a line past MAX_LINE whatever it holds.
    Bytes after the last newline are not a line yet."""
    n = 0
    for line in data.split(b"\n")[:-1]:
        if len(line) > MAX_LINE:
            n += 1
            continue
        try:
            text = line.decode()
        except UnicodeError:
            n += 1
            continue
        blank = not text.strip() if kind == "cpython" else not line.strip(b" \t\r\x0b\x0c")
        n += 0 if blank else 1
    return n


def _default_text(key):
    v = SCHEMA[key][0]
    return v if isinstance(v, str) else json.dumps(v)


class Hang(Exception):
    pass


class Harness:
    """One firmware on a pty, restarted when it dies or its simulated time runs out."""

    def __init__(self, root, kind="micropython", seed=5, case_timeout_s=60.0):
        self.root = root
        self.kind = kind
        self.seed = seed
        self.case_timeout_s = case_timeout_s
        self.boots = 0
        self.dev = self.ser = self.client = None
        self.tally = collections.Counter({"failed cases": 0, "died": 0, "hung": 0})
        self.failures = []     # (input bytes, [problems])
        self._start()

    # ---- the device ----
    def _start(self):
        self.boots += 1
        w = make_world(serial="pty", motion="stationary", seconds=SECONDS, seed=self.seed + self.boots)
        self.dev = start_device(w, os.path.join(self.root, "boot%d" % self.boots), kind=self.kind)
        self.dev.run_until(0.3)
        self.ser = serial.Serial(w.serial_port, timeout=1, exclusive=True)
        self.client = Client(self.ser, self.dev, dt=0.02)

    def close(self):
        if self.dev is None:
            return
        try:
            self.ser.close()
        finally:
            try:
                self.dev.close()
            except (DeviceDied, OSError):
                pass
            self.dev = None

    def _kill(self):
        proc = getattr(self.dev, "proc", None)
        if proc is not None and proc.poll() is None:
            proc.kill()
        self.close()

    def _restart(self):
        self._kill()
        self._start()

    # ---- sending and waiting ----
    def _write(self, data):
        """At most PER_PASS bytes reach the firmware per main-loop pass, as on a board (a USB
        CDC buffer; hal_micropython reads 64 bytes a pass): the simulation's link would hand
        it a whole burst in one read, an allocation no board makes."""
        for i in range(0, len(data), PER_PASS):
            if i:
                self.client.step()
            self.client.write(data[i:i + PER_PASS])

    def _replies(self, start):
        return [d for d in self.client.seen[start:] if "ok" in d]

    def _until_replies(self, start, n, budget_s, extra=True):
        c = self.client
        t_end = self.dev.world.time + budget_s
        while len(self._replies(start)) < n and self.dev.world.time < t_end:
            c.step()
        if extra:
            c.step()      # one more pass: a reply too many would show here
        return self._replies(start)

    def ask(self, line):
        start = len(self.client.seen)
        self._write(line.encode() + b"\n")
        got = self._until_replies(start, 1, 2.0, extra=False)
        return got[0] if got else None

    # ---- one case ----
    def check(self, data):
        """Send `data`, then `version`; the problems found (empty: every property held)."""
        self.tally["cases"] += 1
        if self.dev is None or self.dev.world.time > SECONDS - 10:
            self._restart()
        problems = []
        old = signal.signal(signal.SIGALRM, self._alarm) if _main_thread() else None
        if old is not None:
            signal.setitimer(signal.ITIMER_REAL, self.case_timeout_s)
        try:
            problems = self._check(data)
        except (DeviceDied, BrokenPipeError) as e:
            self.tally["died"] += 1
            problems.append("the firmware died: %s" % _last_line(self._death(e)))
            self._restart()
        except Hang:
            self.tally["hung"] += 1
            problems.append("no progress for %.0f s of wall time (hung)" % self.case_timeout_s)
            self._restart()
        finally:
            if old is not None:
                signal.setitimer(signal.ITIMER_REAL, 0)
                signal.signal(signal.SIGALRM, old)
        if problems:
            self.tally["failed cases"] += 1
            self.failures.append((data, problems))
        return problems

    def _death(self, e):
        """What the firmware's interpreter said as it died (its stderr's tail)."""
        if isinstance(e, DeviceDied):
            return str(e)
        try:
            self.dev._died()          # MicroPythonDevice: waits, reads its stderr, raises
        except DeviceDied as died:
            return str(died)
        except Exception as other:  # noqa: BLE001 - the runner kind has no stderr to read
            return "%r (%r)" % (e, other)
        return repr(e)

    def _alarm(self, signum, frame):
        raise Hang()

    def _check(self, data):
        c = self.client
        problems = []
        sent = data + (b"" if data.endswith(b"\n") else b"\n") + b"version\n"
        want = expected_replies(sent, "cpython" if self.kind == "cpython" else "micropython")
        self.tally["lines"] += want
        start = len(c.seen)
        junk0 = len(c.junk)
        out0 = len(self.dev.world.out)
        self._write(sent)
        got = self._until_replies(start, want, 3.0 + 0.002 * want)
        for d in got:
            self.tally["reply " + (d.get("error", "?") if d.get("ok") is False else "ok")] += 1
            bad = _bad_reply(d)
            if bad:
                problems.append(bad)
        if len(got) != want:
            problems.append("%d replies to %d request lines" % (len(got), want))
        elif not (got[-1].get("ok") is True and got[-1].get("cmd") == "version"):
            problems.append("the last reply is not the version that ends the case: %s" % _short(got[-1]))
        if len(c.junk) > junk0:
            self.tally["junk lines"] += len(c.junk) - junk0
            problems.append("non-JSON on the line: %r" % (c.junk[junk0][:120],))
        try:      # JSON text is UTF-8 (RFC 8259); Python's json.loads lets surrogates pass
            self.dev.world.out[out0:].decode("utf-8")
        except UnicodeDecodeError as e:
            self.tally["non-UTF-8 output"] += 1
            problems.append("output not UTF-8: %r" % (bytes(self.dev.world.out[out0 + max(0, e.start - 60):out0 + e.end + 20]),))
        accepted = any(d.get("cmd") == "set-cal" and d.get("ok") is True for d in got)
        problems += self._restore(sent)
        if accepted:
            self.tally["set-cal accepted"] += 1
            problems += self._survey_streams()
        return problems

    def _restore(self, sent):
        """Undo what the case may have changed, in one burst: a calibration session cancelled,
        every config key it named back to its default (window first: window <= decim), the
        stream off. A set calibration stays, as it would on a device."""
        keys = {_config_key(line) for line in sent.split(b"\n")} - {None}
        lines = ["cancel-cal"] if b"start-cal" in sent else []
        lines += ["config set %s %s" % (k, _default_text(k)) for k in sorted(keys, key=lambda k: k != "window")]
        if b"stream" in sent:
            lines.append("stream off")
        if not lines:
            return []
        start = len(self.client.seen)
        self._write("".join(x + "\n" for x in lines).encode())
        got = self._until_replies(start, len(lines), 2.0, extra=False)
        failed = [x for x, d in zip(lines, got) if x.startswith("config") and not d.get("ok")]
        failed = [x for x in failed if not (self.ask(x) or {}).get("ok")]     # decim before window
        if len(got) < len(lines) or failed:
            return ["restoring the defaults after the case: %d of %d replies, failed %s" % (len(got), len(lines), failed)]
        return []

    def _survey_streams(self):
        """After an accepted set-cal: corrected data for a few survey blocks, finite or null."""
        c = self.client
        n0 = len(c.events("data"))
        r = self.ask("stream corrected")
        if r is None or not r.get("ok"):
            return ["stream corrected after an accepted set-cal: %s" % _short(r)]
        c.step(0.45)
        data = c.events("data")[n0:]
        self.ask("stream off")
        if len(data) < 2:
            s = self.ask("status") or {}
            return ["after an accepted set-cal, %d data events in 0.45 s of survey (want >= 2); status: %s"
                    % (len(data), _short({k: s.get(k) for k in ("state", "fault", "fault_code", "last_error",
                                                                   "samples", "frames")}))]
        for d in data:
            nums = list(d.get("b") or []) + [d.get("f"), d.get("temp")]
            if len(d.get("b") or []) != 3 or not all(x is None or (isinstance(x, (int, float)) and math.isfinite(x))
                                                     for x in nums):
                return ["a data event after set-cal: %s" % _short(d)]
        self.tally["survey checks"] += 1
        return []


def _main_thread():
    import threading
    return threading.current_thread() is threading.main_thread()


def _last_line(text):
    lines = [x for x in text.strip().splitlines() if x.strip()]
    return " | ".join(lines[-3:])[-400:]


def _short(d):
    t = json.dumps(d) if d is not None else "no reply"
    return t if len(t) < 200 else t[:197] + "..."


def _bad_reply(d):
    if d.get("v") != 1 or d.get("ok") not in (True, False) or not isinstance(d.get("cmd"), str):
        return "a malformed reply: %s" % _short(d)
    if d["ok"] is False:
        if not (isinstance(d.get("error"), str) and d["error"] and isinstance(d.get("msg"), str)):
            return "an error reply without a code and message: %s" % _short(d)
        if d["error"] == "internal_error":
            return "internal_error (a firmware bug, by the protocol): %s" % _short(d)
    return None


def _config_key(line):
    words = line.split()
    if len(words) >= 3 and words[0] == b"config" and words[1] == b"set":
        key = words[2].decode(errors="replace")
        return key if key in SCHEMA else None
    return None


def failure_kinds(failures):
    """[(kind, [(input, problems), ...])], most frequent first; a kind is a problem's
    text before its first colon, numbers left out."""
    groups = collections.OrderedDict()
    for data, problems in failures:
        for p in problems:
            kind = "".join("N" if ch.isdigit() else ch for ch in p.split(":")[0].split(";")[0]).strip()
            groups.setdefault(kind, []).append((data, problems))
    return sorted(groups.items(), key=lambda kv: -len(kv[1]))


def run(cases, seed=1, kind="micropython", flood_max=200, progress=True, root=None):
    """Run `cases` random cases; (tally Counter, failures [(input, problems)])."""
    draw = RandomDraw(seed)
    with tempfile.TemporaryDirectory(dir=root) as tmp:
        h = Harness(tmp, kind=kind, seed=seed)
        t0 = time.monotonic()
        try:
            for i in range(cases):
                h.check(case(draw, flood_max=flood_max))
                if progress and (i + 1) % 100 == 0:
                    sys.stderr.write("%d cases, %d failed, %.0f s\n" % (i + 1, h.tally["failed cases"],
                                                                       time.monotonic() - t0))
        finally:
            h.close()
        h.tally["boots"] = h.boots
        h.tally["wall s"] = int(time.monotonic() - t0)
    return h.tally, h.failures


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.fuzz", description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", type=int, default=2000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--kind", default="micropython", help="micropython (default), micropython-float32, "
                   "micropython-reprc, circuitpython, or cpython (in-process)")
    p.add_argument("--flood-max", type=int, default=200, help="lines in the largest flood")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--save", help="write every failing input (exact bytes, as latin-1 text) to this JSON file")
    a = p.parse_args(argv)
    tally, failures = run(a.cases, a.seed, a.kind, a.flood_max, progress=not a.quiet)
    print("fuzz: %d cases on %s, seed %d" % (a.cases, a.kind, a.seed))
    width = max(len(k) for k in tally)
    for k in sorted(tally, key=lambda k: (not k.startswith(("cases", "lines", "failed", "died", "hung")), k)):
        print("  %-*s %8d" % (width, k, tally[k]))
    for kind, cases in failure_kinds(failures):
        print("FAIL x%d: %s" % (len(cases), kind))
        for data, problems in cases[:2]:
            print("  input %r" % (data if len(data) < 300 else data[:300] + b"...",))
            for p in problems:
                print("    " + p[:300])
    if a.save:
        with open(a.save, "w") as f:
            json.dump([{"input": d.decode("latin-1"), "problems": p} for d, p in failures], f, indent=1)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
