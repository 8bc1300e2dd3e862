"""A session the laptop holds open (`start-cal ... hold`) and the direction the progress events carry.

In-process firmware on the simulator's handheld (desktop/devicesim/world.py), as
tests/test_device_calibration.py runs its failure paths.
"""

import json
import math

from desktop.devicesim.procedure import events
from desktop.views.coverage_text import TurnWatch
from tests.device_session import configured as _device


def _angle(u, v):
    dot = sum(a * b for a, b in zip(u, v)) / math.sqrt(sum(a * a for a in u) * sum(b * b for b in v))
    return math.degrees(math.acos(max(-1.0, min(1.0, dot))))


def test_a_held_session_waits_past_ready_for_finish_cal(tmp_path):
    # auto_finish is on (the default): without hold the hand's session finishes by itself at
    # the first provisional solve that is ready (11 s measured, tests/test_device_calibration.py)
    w, dev = _device(tmp_path, "hand", 40.0)
    w.send(b"start-cal full hold\n")
    dev.run_until(30.0)
    cal = events(w, "cal")
    assert all(e["state"] == "collecting" for e in cal), [e for e in cal if e["state"] != "collecting"]
    assert any(e["ready"] for e in cal) and all(e["hold"] for e in cal)
    w.send(b"finish-cal\n")
    dev.run_until(30.5)
    done = [e for e in events(w, "cal") if e["state"] != "collecting"]
    assert len(done) == 1 and done[0]["state"] == "done", done
    dev.close()


def test_hold_is_a_word_of_its_own(tmp_path):
    w, dev = _device(tmp_path, "hand", 2.0)
    w.send(b"start-cal full hold quick\n")
    dev.run_until(0.7)
    reply = [json.loads(x) for x in w.lines() if '"cmd": "start-cal"' in x][-1]
    assert reply["error"] == "bad_argument" and "[hold]" in reply["msg"], reply
    dev.close()


def test_progress_says_where_the_sensor_points(tmp_path):
    """Held still, the direction stays within the noise's angle (0.1 nT of 50,000: far under a
    degree) and the laptop's watch says it is not turning; turned by hand, it sweeps."""
    w, dev = _device(tmp_path, "stationary", 8.0)
    w.send(b"start-cal full\n")
    dev.run_until(7.5)
    dirs = [e["dir"] for e in events(w, "cal") if e.get("dir")]
    assert len(dirs) >= 5
    assert max(_angle(dirs[0], d) for d in dirs) < 1.0, dirs
    watch = TurnWatch()
    for k, e in enumerate(e for e in events(w, "cal") if e.get("dir")):
        watch.add(float(k), e["dir"], e["coverage"])        # progress events come once a second
    assert watch.warning().startswith("NOT TURNING"), watch.warning()
    dev.close()

    w, dev = _device(tmp_path / "hand", "hand", 8.0)
    w.send(b"start-cal full\n")
    dev.run_until(7.5)
    dirs = [e["dir"] for e in events(w, "cal") if e.get("dir")]
    assert max(_angle(dirs[0], d) for d in dirs) > 30.0, dirs   # more than a cell (22.5 degrees)
    watch = TurnWatch()
    for k, e in enumerate(e for e in events(w, "cal") if e.get("dir")):
        watch.add(float(k), e["dir"], e["coverage"])
    assert watch.warning() is None, watch.warning()
    dev.close()
