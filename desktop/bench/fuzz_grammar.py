"""The fuzzer's grammar: the bursts of bytes a case sends down the serial line.

A case is a command from the firmware's table (device/commands.py) with generated
arguments, a set-cal record mutated field by field, a `config set` of a key of
device/config.py's SCHEMA to a generated value, random bytes (NUL, Ctrl-C, invalid
UTF-8), lines at and past the 2048-byte limit, or a flood; "mixed" strings a few together.

The grammar is written against a small `draw` interface (pick, int, real, raw, chance,
order): :class:`RandomDraw` over random.Random for the long runs (desktop/bench/fuzz.py),
tests/test_protocol_fuzz.py's over hypothesis (bounded, shrunk to a minimal failing input).
"""

import json
import math
import random

from desktop.firmware.files import import_device

_commands = import_device("commands")
_config = import_device("config")
MAX_LINE = import_device("protocol").MAX_LINE
SCHEMA = _config.SCHEMA
# `repl` hands the line to the REPL and ends main.py: a case of its own (tests/test_device_repl.py)
COMMANDS = sorted(c for c in _commands.TABLE if c != "repl")
K = SCHEMA["scale_x"][0]          # nT per code of the default front end


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
    elif kind in ("bool", "bool_auto"):
        valid += [True, False, 0, 1, "yes", "auto", "AUTO"]
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
