"""`fluxcal emulate --runtime pico` from the laptop: the rp2 port's own firmware on an emulated Pico
with the simulated handheld on its pins, every step a `fluxcal` command as typed.

One test, one emulator: its deploy and each boot cost tens of wall seconds (the Pico runs slower
than real time), and a module-scoped emulator would be started once per xdist worker. In order:
1. clients that come while the emulator deploys its own firmware are told it is busy, and the
   emulator carries on to "ready";
2. the button pressed (key p) starts a calibration, its closing timed by the pin's interrupt;
   every laptop command (status, calibrate --auto, pull-cal, push-cal, capture, report, monitor);
   the calibration with a shorter configuration (SHORT_CAL), set over the protocol as a user
   would with `config set`, after a session started and cancelled; a quick one starts after the
   survey (a small heap in pieces: calibration_flow.py start);
3. a power cycle brings the calibration back from the flash, and the chips answer again;
4. the watchdog: the line handed to the REPL (`repl`) stays there through mpremote's soft reset
   and longer than the watchdog's longest timeout; then a main.py of the test's own (no test hook
   in the firmware) hangs the main loop: the watchdog resets the board and the boot guard counts
   the hung boot;
5. `q` ends the emulator and its runner, the flash file whole.
The commands get a longer --timeout, as for any slow board.
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
MPREMOTE = [sys.executable, "-m", "mpremote"]
SLOW = ("--timeout", "30")
BUSY = "fluxcal: the emulated board is busy deploying its firmware; try again in a moment"
# fewer conversions and samples to emulate (250 SPS, a 2-conversion boxcar every 5: 50 samples/s;
# 125 SPS left a residual over max_rms_nt), a provisional solve every 2 s, finished at 30 % of the
# sphere and 2 nT predicted, or at 10 s of turning with what it has; measured 45 s of wall time
SHORT_CAL = {"rate": 250, "decim": 5, "solve_every_s": 2, "max_cal_s": 10, "min_coverage": 0.3,
             "target_error_nt": 2.0}
WATCHDOG_MS = 1000     # the shortest the config allows: the hung loop costs 1 emulated s
# the test's own main.py: the firmware, whose main loop hangs at its first pass when the file
# hang-once is there (a hang after the boot became healthy: test_reliability_firmware.py)
HANG_MAIN = """import os
import app
import hal_micropython

try:
    os.remove("hang-once")

    def _stuck(self):
        while True:   # a main loop that never comes back: only the watchdog ends it
            pass
    app.App.step = _stuck
except OSError:
    pass
app.start(hal_micropython)
"""

def fluxcal(*args, timeout=300):
    return subprocess.run([FLUXCAL, *map(str, args)], capture_output=True, text=True, cwd=ROOT, timeout=timeout)


def ok(r):
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stdout + r.stderr
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


def ask(port, *commands, timeout=30.0):
    """The replies to each command, over one connection."""
    from desktop.link import open_device
    dev = open_device(port, timeout=timeout)
    try:
        return [dev.ask(c) for c in commands]
    finally:
        dev.close()


def mpremote(port, *words, timeout=300):
    r = subprocess.run(MPREMOTE + ["connect", port, *words], capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def boot_after_a_hang(port, deadline):
    """The status of the first boot that follows a watchdog reset (the firmware answers until
    its loop hangs, then not at all until the reset)."""
    from desktop.link import LinkError
    while True:
        try:
            st = ask(port, "status", timeout=5.0)[0]
        except LinkError:
            st = None
        if st is not None and st["watchdog_reset"]:
            return st
        assert time.monotonic() < deadline, "no watchdog reset: %s" % st
        time.sleep(1.0)


def runners_on(flash):
    out = subprocess.run(["pgrep", "-f", "runner.mjs.*%s" % flash], capture_output=True, text=True).stdout
    return out.split()


def test_the_laptop_commands_a_power_cycle_and_the_watchdog_on_the_emulated_pico(tmp_path):
    need("rp2-pico")
    flash = tmp_path / "flash"
    emu = subprocess.Popen([FLUXCAL, "emulate", "--runtime", "pico", "--flash", flash], cwd=ROOT,
                           stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        # 1. too early: one line each, and the emulator's own deploy goes on
        port = read_until(emu, " on /dev/", 60).split(" on ")[-1].strip()
        for command in ("status", "deploy"):
            r = fluxcal(command, "--port", port, timeout=60)
            assert r.returncode == 1 and r.stderr.strip() == BUSY, (command, r.stdout, r.stderr)
        said = read_until(emu, "ready: the firmware runs", 900)
        assert "deployed" in said, said

        # 2. the laptop commands
        status = json.loads(ok(fluxcal("status", "--json", "--port", port, *SLOW)))
        assert status["version"]["runtime"] == "micropython-rp2", status
        st = status["status"]
        assert st["calibrated"] is False and st["missed"] == 0, st
        # the RP2040 has the watchdog the firmware can hand back: the main loop runs with it
        assert st["watchdog_ms"] == 5000 and st["watchdog_reset"] is False, st
        ask(port, *("config set %s %s" % kv for kv in SHORT_CAL.items()))
        # deploy put gatesc.mpy on: a session's gates run in C (status while it collects says so);
        # a session cancelled, then another started: each takes its modules and buffers again
        # from a heap the last one left in pieces (calibration_flow.py start; docs/firmware.md)
        started, during, _ = ask(port, "start-cal", "status", "cancel-cal")
        assert started["ok"] and during["cal"]["gates"] == "native", during
        # the button (the operator's key p, 0.2 s): its closing timed by the pin's hard IRQ, a short
        # press starts a calibration
        assert during["button"] == "interrupt", during
        emu.stdin.write("p")
        emu.stdin.flush()
        deadline = time.monotonic() + 120
        while ask(port, "status")[0]["state"] != "calibrating":
            assert time.monotonic() < deadline, "the press started no calibration"
            time.sleep(1.0)
        assert ask(port, "cancel-cal")[0]["ok"]
        out = ok(fluxcal("calibrate", "--auto", "--port", port, *SLOW, timeout=600))   # the operator follows the LED
        assert "calibration done" in out and "saved, in force" in out, out
        ok(fluxcal("pull-cal", "-o", tmp_path / "device.json", "--port", port, *SLOW))
        ok(fluxcal("push-cal", tmp_path / "device.json", "--port", port, *SLOW))
        ok(fluxcal("capture", "--seconds", 3, "-o", tmp_path / "capture.npz", "--port", port, *SLOW))
        ok(fluxcal("report", tmp_path / "capture.npz", "--cal", tmp_path / "device.json", "-o", tmp_path / "report"))
        assert (tmp_path / "report" / "summary.md").exists()
        out = ok(fluxcal("monitor", "--seconds", 3, "--port", port, *SLOW))   # survey output, corrected
        assert "|B|" in out, out
        # a quick re-calibration starts after a calibration and a survey, without a reboot
        started, _ = ask(port, "start-cal quick", "cancel-cal")
        assert started["ok"], started

        # 3. the power switch, off and on: the calibration comes back from the flash
        emu.stdin.write("c")
        emu.stdin.flush()
        time.sleep(1.0)
        st = json.loads(ok(fluxcal("status", "--json", "--port", port, *SLOW)))["status"]
        assert st["calibrated"] is True and st["uptime_ms"] < 60000, st
        # deploy put the armv6m fitsums.mpy, drdy.mpy and screenc.mpy on: the fit's sums, the survey's
        # |h_c|, the DRDY handler (a hard IRQ calling the HAL's Pins and SPI read) and the spike
        # screen's push run in C; so do the ring's reader and the output's sample (drdy.Drain, drdy.Sample)
        assert (st["sums"], st["magnitude"], st["drdy"], st["screen"]) == ("native",) * 4, st
        assert st["linalg"] == "python", st     # the float kernels: not beside the .mpy firmware's heap (app.py)
        assert (st["reader"], st["sample"]) == ("native",) * 2, st
        # a PIO state machine counts the 3 conversions of every 5 the boxcar does not read; the
        # handler accounts them: a block's 5 conversions for each sample read (and the ring's
        # and the open block's not yet read), none missed
        assert st["drdy_counter"] == "pio" and st["missed"] == 0, st
        assert 5 * st["samples"] <= st["frames"] < 5 * (st["samples"] + 128 + 1), st
        ok(fluxcal("pull-cal", "-o", tmp_path / "after.json", "--port", port, *SLOW))
        before, after = (json.loads((tmp_path / n).read_text()) for n in ("device.json", "after.json"))
        assert before["matrix"] == after["matrix"] and before["offset"] == after["offset"]
        out = ok(fluxcal("monitor", "--seconds", 3, "--port", port, *SLOW))   # and the chips answer again
        assert "|B|" in out, out

        # 4. the watchdog, handed back to the REPL: 9 s there (> 8.388 s) after a soft reset
        ask(port, "config set watchdog_ms %d" % WATCHDOG_MS, "repl")
        (tmp_path / "main.py").write_text(HANG_MAIN)
        mpremote(port, "fs", "cp", str(tmp_path / "main.py"), ":main.py", "+",
                 "exec", "open('hang-once', 'w').close(); import time; time.sleep(9)")
        assert "hang-once" in mpremote(port, "fs", "ls"), "the board reset while the REPL had the line"
        mpremote(port, "reset")
        st = boot_after_a_hang(port, deadline=time.monotonic() + 600)
        assert st["unfinished_boots"] == 1, st            # the hung boot, counted by the guard
        assert st["safe_mode"] is None and st["calibrated"] is True, st     # one hang: measuring on
        assert st["watchdog_ms"] == WATCHDOG_MS, st
    finally:
        if emu.poll() is None:
            emu.stdin.write("q")
            emu.stdin.flush()
        out, err = emu.communicate(timeout=60)
    # 5. the end: the runner went with it, the flash file whole
    assert emu.returncode == 0, err
    assert not runners_on(flash)
    assert os.path.getsize(flash / "pico.flash") == 2 * 1024 * 1024
