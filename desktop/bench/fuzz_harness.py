"""The fuzzer's harness: one firmware on a pty, a case sent, the protocol's properties checked.

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
"""

import collections
import json
import math
import os
import signal

import serial

from desktop.devicesim.client import Client
from desktop.devicesim.runners import DeviceDied, start_device
from desktop.devicesim.world import make_world
from desktop.firmware.files import import_device

MAX_LINE = import_device("protocol").MAX_LINE
SCHEMA = import_device("config").SCHEMA
SECONDS = 60.0                    # simulated seconds per device; restarted before they run out
PER_PASS = 512                    # bytes of a burst the firmware gets per main-loop pass (Harness._write)


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
