"""The virtual handheld: a live operator, a live analog world, and a board on a pseudo-terminal
that boots the firmware through its own HAL in real time (desktop/devicesim/virtual_handheld.py).

Real parts: the interpreters a board has, the stand-ins of desktop/devicesim/stand-ins/, mpremote
and pyserial on a real pty. Timings here are wall time on a shared machine, so the tests wait on
what the firmware says, with generous deadlines, never on a stopwatch.
"""

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from desktop.devicesim.procedure import events, handheld_config
from desktop.devicesim.runners import install_firmware, start_device, write_config
from desktop.devicesim.virtual_handheld import Hands, VirtualHandheld, led_says_turn, live_world
from desktop.firmware.files import import_device
from desktop.sim.motion import rotation_rate
from desktop.sim.operator import LiveOperator
from tests.interpreters import need
from tests.port_read import read_until

led = import_device("led")
RATE = import_device("config").SCHEMA["rate"][0]    # SPS: the virtual handheld's wiring keeps the default


def angle(qa, qb):
    return 2 * np.arccos(np.clip(np.abs(np.sum(qa * qb, axis=-1)), 0, 1))


def test_live_operator_switches_without_a_jump():
    op = LiveOperator(np.random.default_rng(3), mode="hold")
    op.set("hand", at=1.0)
    op.set("spin", at=70.0)          # past the first stretch of hand motion (60 s)
    op.set("hold", at=80.0)
    eps = 1e-4
    for t in (1.0, 60.0, 70.0, 80.0):
        q = op.orientation(np.array([t - eps, t + eps]))
        assert angle(q[0], q[1]) < 0.01, t            # continuous: at most a turn rate times 2 eps
    t = np.linspace(0.1, 0.9, 50)
    assert np.all(angle(op.orientation(t), op.orientation(np.array([0.5]))) < 1e-12)    # hold
    rate = rotation_rate(op, np.linspace(71, 79, 50))
    assert np.allclose(rate, 2 * np.pi, rtol=1e-3)    # spin: 1 rev/s about the vertical
    hand = rotation_rate(op, np.linspace(5, 55, 500))
    assert 0.5 * 2 * np.pi < hand.mean() < 1.5 * 2 * np.pi          # ~1 rev/s by hand
    with pytest.raises(ValueError):
        op.set("juggle", at=90.0)


def _edges(pattern, seconds=3.0):
    """The LED's (time, level) log as device/led.py drives it with `pattern`."""
    log, t, level, k = [], 0.0, True, 0
    while t < seconds:
        log.append((t, level))
        t += pattern[k % len(pattern)] / 1000.0
        level, k = not level, k + 1
    return log, seconds


@pytest.mark.parametrize("name, turn", [("COLLECTING", True), ("ENOUGH", True), ("SURVEY", False),
                                        ("UNCALIBRATED", False), ("DONE", False), ("FAULT", False)])
def test_the_operator_reads_the_led_as_the_manual_says(name, turn):
    log, now = _edges(getattr(led, name))
    assert led_says_turn(log, now) is turn


def test_live_world_calibrates_with_the_led_following_operator(tmp_path):
    """Simulated time, in process: the analog input computed just ahead of the chips, the operator
    turning while the LED says collecting; the firmware auto-finishes as with a scripted capture."""
    world, operator = live_world(seed=2, motion_seed=5)
    hands = Hands(world, operator)
    write_config(str(tmp_path), **handheld_config(world.scenario))
    dev = start_device(world, str(tmp_path), kind="cpython")
    try:
        dev.run_until(0.5)
        world.press(0.2)
        turned = False
        while world.time < 40.0 and not [e for e in events(world, "cal") if e.get("state") == "done"]:
            dev.run_until(world.time + 0.05)
            hands.step()
            turned = turned or operator.mode == "hand"
        done = [e for e in events(world, "cal") if e.get("state") == "done"]
        assert turned and done and done[0]["saved"], events(world, "cal")[-1]
        dev.run_until(world.time + 3.0)
        hands.step()
        assert operator.mode == "hold"                # the LED says done, then survey: hold still
    finally:
        dev.close()


def _ask(ser, line, timeout=5.0):
    ser.write(b"\n" + line.encode() + b"\n")    # a newline first: ends whatever was on the line
    buf = read_until(ser, b'"cmd": "%s"' % line.split()[0].encode(), timeout)
    for ln in buf.split(b"\n"):
        try:
            d = json.loads(ln)
        except ValueError:
            continue
        if d.get("cmd") == line.split()[0]:
            return d
    raise AssertionError("no reply to %r: %r" % (line, buf[-300:]))


@pytest.mark.parametrize("runtime", ["micropython", "circuitpython"])
def test_the_board_boots_its_firmware_and_answers_in_real_time(runtime, tmp_path):
    need(runtime)
    flash = str(tmp_path / "flash")
    os.makedirs(flash)
    hh = VirtualHandheld(flash, runtime=runtime)
    install_firmware(flash, hh.runtime)
    import_device("store").save(flash, "config", hh.wiring_config())
    with hh:
        ser = serial.Serial(hh.port, timeout=0.2, exclusive=True)
        assert b'"ev": "boot"' in read_until(ser, b'"ev": "boot"', 15.0)
        v = _ask(ser, "version")
        assert v["ok"] and v["impl"] == runtime and v["runtime"].startswith(runtime)
        s0 = _ask(ser, "status")
        time.sleep(2.0)       # a while of live running (how fast it goes is the handheld bench's figure)
        s1 = _ask(ser, "status")
        # the firmware's clock and the conversions it counted agree: the data rate, to within
        # a main-loop pass of conversions (20 ms: a polled HAL counts them there) and a ms of
        # ticks, at each of the two readings
        age = (s1["uptime_ms"] - s0["uptime_ms"]) / 1000.0
        frames = s1["frames"] - s0["frames"]
        assert age > 0 and abs(frames - RATE * age) <= 2 * RATE * (0.020 + 0.001), (s0, s1)
        assert s1["frames"] > 1000 and s1["overflow"] == 0 and s1["badsync"] == 0


def test_calibrating_the_virtual_handheld_from_its_serial_line(tmp_path):
    """start-cal on the pty; the operator follows the LED (nobody at the keyboard); the firmware
    auto-finishes and stores the calibration, in real time."""
    flash = str(tmp_path / "flash")
    os.makedirs(flash)
    hh = VirtualHandheld(flash, runtime="micropython", seed=1)
    install_firmware(flash, hh.runtime)
    with hh:
        ser = serial.Serial(hh.port, timeout=0.2)
        read_until(ser, b'"ev": "boot"', 15.0)
        assert _ask(ser, "start-cal")["ok"]
        buf = read_until(ser, b'"state": "done"', 60.0)
        assert b'"state": "done"' in buf, buf[-400:]
        # paced: the pacer never lets simulated time run ahead of the wall clock, so >= 11 s of
        # rotation took >= 11 s here and it has measured its capacity (over 5 s windows). How
        # much it had to spare is the handheld bench's figure: a speed, not asked of a test.
        assert hh.pacer.capacity is not None
        assert _ask(ser, "status")["calibrated"]
        assert os.path.exists(os.path.join(flash, "cal.json"))


def test_resets_as_a_board_resets(tmp_path):
    """A bare board: mpremote runs code at its REPL; a soft reset from the raw REPL (mpremote does
    one when it first enters it, and `soft-reset`) runs boot.py but not main.py; `mpremote reset`
    (machine.reset) and a power cycle run both."""
    flash = tmp_path / "flash"
    flash.mkdir()
    (flash / "boot.py").write_text("open('booted', 'a').write('b')\n")
    (flash / "main.py").write_text("open('booted', 'a').write('m')\n")
    mp = [sys.executable, "-m", "mpremote"]
    with VirtualHandheld(str(flash)) as hh:
        def run(*words):
            r = subprocess.run(mp + ["connect", hh.port] + list(words), capture_output=True, text=True, timeout=30)
            assert r.returncode == 0, r.stderr
            return r.stdout

        def boots_after(action, settle=1.5):
            """What boot.py ('b') and main.py ('m') wrote because of `action`."""
            before = (flash / "booted").read_text() if (flash / "booted").exists() else ""
            action()
            end = time.monotonic() + 10
            text = before
            while time.monotonic() < end:
                time.sleep(settle)
                now = (flash / "booted").read_text()
                if now == text and now != before:
                    break
                text = now
            return text[len(before):]

        end = time.monotonic() + 10
        while time.monotonic() < end and not (flash / "booted").exists():
            time.sleep(0.1)
        time.sleep(0.5)
        assert (flash / "booted").read_text() == "bm"                         # power-up: both
        added = boots_after(lambda: run("exec", "print(6 * 7)"))
        assert set(added) <= {"b"}                        # mpremote's soft reset: boot.py only
        assert set(boots_after(lambda: run("soft-reset"))) == {"b"}
        assert boots_after(lambda: run("reset")).endswith("bm")                # hard reset: both
        assert boots_after(lambda: hh.act("power-cycle")) == "bm"


def test_a_field_step_reaches_the_stream(tmp_path):
    """field-step: the live world's field grows from the first moment not yet computed, and the
    firmware's |B| follows (the sensor held still; nominal scale, so about the step itself)."""
    world, operator = live_world(seed=3)
    hands = Hands(world, operator)
    hands.act("hold")
    write_config(str(tmp_path), **handheld_config(world.scenario))
    dev = start_device(world, str(tmp_path), kind="cpython")
    try:
        dev.run_until(0.3)
        world.send(b"stream on corrected\n")
        dev.run_until(2.0)
        hands.step()
        hands.act("field-step", "100")
        hands.step()
        t_step = hands.field_steps[0][0]
        dev.run_until(t_step + 2.0)
        data = [e for e in events(world, "data")]
        before = [e["f"] for e in data if e["t"] / 1000.0 < t_step - 0.2]
        after = [e["f"] for e in data if e["t"] / 1000.0 > t_step + 0.3]
        assert before and after
        assert abs(np.mean(after) - np.mean(before) - 100.0) < 5.0, (np.mean(before), np.mean(after))
    finally:
        dev.close()
