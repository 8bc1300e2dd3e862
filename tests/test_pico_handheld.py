"""`fluxcal emulate --runtime pico` from the laptop: the rp2 port's own firmware on an emulated
Pico with the simulated handheld on its pins, every step a `fluxcal` command as typed.

The emulated Pico runs slower than real time (about 0.4 emulated s per wall s when its core is
busy, less on a loaded host), so the laptop commands are given a longer --timeout, as for any
slow board. A full calibration takes minutes of wall time there: the calibration here is pushed,
and what is checked is that the board keeps it in its flash over a power cycle.
"""

import json
import os
import select
import subprocess
import sys
import time

from tests.interpreters import need

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FLUXCAL = os.path.join(os.path.dirname(sys.executable), "fluxcal")
SLOW = ("--timeout", "60")


def fluxcal(*args, timeout=300):
    r = subprocess.run([FLUXCAL, *map(str, args)], capture_output=True, text=True, cwd=ROOT, timeout=timeout)
    assert r.returncode == 0 and "Traceback" not in r.stderr, "fluxcal %s: %s%s" % (args[0], r.stdout, r.stderr)
    return r.stdout


def read_until(proc, word, timeout):
    seen = []
    end = time.monotonic() + timeout
    while time.monotonic() < end and proc.poll() is None:
        if select.select([proc.stdout], [], [], 0.5)[0]:
            line = proc.stdout.readline()
            seen.append(line)
            if word in line:
                return "".join(seen)
    raise AssertionError("no %r from fluxcal emulate: %s" % (word, "".join(seen)))


def runners_on(flash):
    out = subprocess.run(["pgrep", "-f", "runner.mjs.*%s" % flash], capture_output=True, text=True).stdout
    return out.split()


def test_emulate_pico_deploys_answers_and_keeps_a_pushed_calibration_over_a_power_cycle(tmp_path):
    need("rp2-pico")
    flash = tmp_path / "flash"
    emu = subprocess.Popen([FLUXCAL, "emulate", "--runtime", "pico", "--flash", flash], cwd=ROOT,
                           stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = read_until(emu, " on /dev/", 60)
        port = first.split(" on ")[-1].strip()
        read_until(emu, "ready: the firmware runs", 900)       # deployed (.mpy for armv6m) and answering
        status = json.loads(fluxcal("status", "--json", "--port", port, *SLOW))
        assert status["version"]["runtime"] == "micropython-rp2", status
        assert status["status"]["calibrated"] is False and status["status"]["missed"] == 0, status

        fitted = {"matrix": [[1.001, 0.002, 0], [0.002, 0.998, 0], [0, 0, 1.0]], "offset": [120.0, -35.5, 60.25],
                  "field": 47200.0, "diagnostics": {"rms": 0.2, "n": 900}, "meta": {"method": "streaming"}}
        (tmp_path / "fitted.json").write_text(json.dumps(fitted))
        fluxcal("push-cal", tmp_path / "fitted.json", "--port", port, *SLOW)
        fluxcal("pull-cal", "-o", tmp_path / "before.json", "--port", port, *SLOW)
        out = fluxcal("monitor", "--seconds", 3, "--port", port, *SLOW)   # survey output, corrected
        assert "|B|" in out, out

        emu.stdin.write("c")                                      # the power switch: off and on
        emu.stdin.flush()
        time.sleep(1.0)
        status = json.loads(fluxcal("status", "--json", "--port", port, *SLOW))
        assert status["status"]["calibrated"] is True and status["status"]["uptime_ms"] < 60000, status
        fluxcal("pull-cal", "-o", tmp_path / "after.json", "--port", port, *SLOW)
        before, after = (json.loads((tmp_path / n).read_text()) for n in ("before.json", "after.json"))
        assert before["matrix"] == after["matrix"] and before["offset"] == after["offset"]
        out = fluxcal("monitor", "--seconds", 3, "--port", port, *SLOW)   # and the chips answer again
        assert "|B|" in out, out

    finally:
        emu.stdin.write("q")
        emu.stdin.flush()
        emu.communicate(timeout=60)
    assert emu.returncode == 0
    assert not runners_on(flash)                                  # the runner went with it
    assert os.path.getsize(flash / "pico.flash") == 2 * 1024 * 1024
