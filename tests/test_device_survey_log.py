"""The firmware's survey mode on every interpreter a board has (device/surveylog.py): the button's
short press is a line mark timed at the press, every block's |B| and every mark go to the flash
log as they go out, the log reads back over the protocol as the laptop parses it, and a full log
keeps the survey's start and says so once while the stream goes on."""

import json

import pytest

from desktop.survey.recording import parse_log
from tests.device_session import ask, boot, events
from tests.interpreters import INTERPRETERS

PASS_MS = 20        # device/app.py _HOUSE_MS: the button is read once a main-loop pass
HEADER, RECORD = 8, 8


def _log(w, dev):
    raw = b""
    while True:
        r = ask(w, dev, "survey read %d" % len(raw))
        raw += bytes.fromhex(r["data"])
        if not r["data"] or len(raw) >= r["size"]:
            return raw


@pytest.mark.parametrize("name", INTERPRETERS)
def test_marks_and_blocks_go_to_the_flash_log_and_a_full_log_keeps_the_start(name, tmp_path):
    w, dev = boot(tmp_path, name, seconds=8.0)
    try:
        ask(w, dev, "stream corrected")
        start = ask(w, dev, "survey start")
        assert start["recording"] and start["marks"] == 0 and start["limit"] > 0, start
        since = len(w.lines())
        presses = [w.time + 0.5, w.time + 2.0]
        for t in presses:
            w.press(0.2, at=t)
        dev.run_until(w.time + 3.0)
        assert ask(w, dev, "set-cal {}")["error"] == "busy" and ask(w, dev, "start-cal")["error"] == "busy"
        recording = w.lines()[since:]       # what went out before `survey stop` was sent
        stop = ask(w, dev, "survey stop")
        marks = events(w, "mark", since)
        # a mark, not a calibration: timed when the contact closed, within a pass (and a ms tick)
        assert [m["n"] for m in marks] == [1, 2] and not events(w, "cal", since), marks
        for m, t in zip(marks, presses):
            assert abs(m["t"] - t * 1000) <= PASS_MS + 1 and m["ms"] == m["t"] - start["t0"], (m, t)
        readings, logged_marks = parse_log(_log(w, dev))
        assert logged_marks == [m["ms"] for m in marks]
        # every block that went out while recording is in the log, to its hundredths of a nT
        data = {d["t"] - start["t0"]: d["f"] for d in (json.loads(x) for x in recording) if d.get("ev") == "data"}
        logged = dict(readings)
        assert len(readings) == stop["records"] and set(data) <= set(logged), (len(data), len(logged))
        # (the log to its hundredths; the event's f to 0.001 nT, but a 32-bit float prints 7
        # significant digits, hundredths at 48,000 nT: half a hundredth each, far below the noise)
        assert max(abs(logged[ms] - f) for ms, f in data.items()) <= 0.01 + 1e-6

        # a log bounded at 7 records: the first 7 blocks kept, one log_full event, the stream on
        since = len(w.lines())
        ask(w, dev, "survey start %d" % (HEADER + 7 * RECORD))
        dev.run_until(w.time + 1.5)
        info = ask(w, dev, "survey info")
        full = events(w, "survey", since)
        assert info["full"] and not info["recording"] and info["bytes"] == HEADER + 7 * RECORD, info
        assert len(full) == 1 and full[0]["state"] == "log_full", full
        readings, _marks = parse_log(_log(w, dev))
        later = [d["t"] for d in events(w, "data", since)]
        # (a block taken in the pass that ran `survey start`, before it, went out unlogged: ms <= 0)
        first = sorted(t - info["t0"] for t in later if t > info["t0"])[:7]
        assert [ms for ms, _f in readings] == first and len(later) > 7 + 5     # and the stream went on
        assert ask(w, dev, "survey stop")["full"]
        assert ask(w, dev, "survey stop")["error"] == "bad_argument"
    finally:
        dev.close()
