"""The operator's guidance from the laptop, against firmware on a real pseudo-terminal in real time
(tests/realtime.py): `calibrate` without --auto waits for the key past `ready`; its piped view names
the gap and warns when the sensor is held still; `capture` of a still sensor warns.
"""

import os
import select
import subprocess
import sys
import time

from tests.realtime import LiveHandheld

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NO_HANG_S = 90      # any fluxcal run here that takes longer has hung


def _lines_until(proc, want, count):
    """stdout lines until `count` of them contain `want` (or the process ends): the lines read."""
    lines, seen = [], 0
    end = time.monotonic() + NO_HANG_S
    while seen < count and time.monotonic() < end and proc.poll() is None:
        if select.select([proc.stdout], [], [], 0.2)[0]:
            line = proc.stdout.readline()
            lines.append(line)
            seen += want in line
    return lines


def _calibrate(port, want, count, key):
    """fluxcal calibrate (piped) until `count` stdout lines contain `want`, then `key`:
    (everything it printed, its stderr, its exit code, the lines seen before the key)."""
    # --timeout 10: a session's start allocates and collects; on a loaded 2-core machine the
    # in-process firmware's reply can take longer than the default 2 s
    proc = subprocess.Popen([sys.executable, "-m", "desktop", "calibrate", "--timeout", "10", "--port", port], cwd=ROOT,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        lines = _lines_until(proc, want, count)
        alive = proc.poll() is None
        if alive:
            proc.stdin.write(key)
            proc.stdin.flush()
        out, err = proc.communicate(timeout=NO_HANG_S)
    finally:
        if proc.poll() is None:
            proc.kill()
    return "".join(lines) + out, err, proc.returncode, (lines if alive else None)


def test_calibrate_without_auto_waits_for_the_key_past_ready(tmp_path):
    with LiveHandheld(tmp_path / "hh", motion="hand", seconds=70, seed=7) as hh:
        # the firmware's auto_finish is on: an unheld session ends at the first solve that finds it
        # ready; held, it reports READY once a second until the key. More READY lines than a solve
        # period (solve_every_s, 5 s) holds, then f:
        out, err, rc, before = _calibrate(hh.port, "READY", 7, "f\n")
        assert before is not None and sum("READY" in line for line in before) == 7, out + err
        assert rc == 0, err
        assert "calibration done" in out and "full calibration" in out, out
        assert "largest gap:" in out and "@ the sensor now" in out, out


def test_a_still_sensor_is_told_to_turn(tmp_path):
    with LiveHandheld(tmp_path / "hh", motion="stationary", seconds=40, seed=3) as hh:
        out, err, rc, before = _calibrate(hh.port, "NOT TURNING", 1, "c\n")
        assert "NOT TURNING: the sensor has pointed the same way for" in out, out
        assert rc == 1 and "calibration cancelled" in err
        cap = subprocess.run([sys.executable, "-m", "desktop", "capture", "--seconds", "3", "-o",
                              str(tmp_path / "still.npz"), "--port", hh.port],
                             cwd=ROOT, capture_output=True, text=True, timeout=NO_HANG_S)
        assert cap.returncode == 0, cap.stderr
        assert "turn the handheld slowly about every axis" in cap.stdout
        assert "WARNING: the recording covers 1 % of the sphere" in cap.stdout, cap.stdout
