"""The one-button calibration end to end on the simulator's handheld (Mag649, hand motion).

The full cycle (boot, press, rotate, auto-finish, store, power cycle, verify
on a 360 degree spin) runs in the real `micropython` executable with the DRDY
handler under heap_lock (a hard IRQ's rule: any allocation raises), and the
failure paths run in-process. Tolerances: the paper's target is 2 nT PTP; the
simulator's own floor for this sensor is ~0.45 nT (docs/simulator.md).
"""

import json
import os

import pytest

from desktop.devicesim.procedure import calibrate_and_verify, events, handheld_config
from desktop.devicesim.runners import start_device, write_config
from desktop.devicesim.world import make_world
from shared import codes
from tests.device_bounds import spin_ptp_bound
from tests.device_session import ask, configured
from tests.interpreters import INTERPRETERS, float_eps, heap_bytes, need

# Auto-finish is decided at provisional solves, every solve_every_s = 5 s from the press; a
# hand at ~1 rev/s covers half the cells with a predicted error far below 1 nT by the second
# (11.0 s measured for 3 sensors x 3 motions): the third solve is the bound.
READY_S = 3 * 5.0 + 1.0
# |B| PTP over the verification spin without a calibration (python -m desktop.bench.device; README, docs)
UNCALIBRATED_PTP_NT = 543.5


@pytest.mark.parametrize("name", INTERPRETERS)
def test_full_calibration_cycle_on_each_interpreter(name, tmp_path):
    need(name)
    r = calibrate_and_verify(kind=name, root=str(tmp_path), rotate_s=60.0, spin_s=10.0)
    cal = r["cal"]
    assert cal["state"] == "done" and cal["saved"] is True, cal
    assert r["rotated_s"] <= READY_S                  # auto-finished: ready at a provisional solve
    assert r["boot"]["calibrated"] and r["boot"]["cal_source"] == "json"   # survived the power cycle
    assert len(r["spin_f_cal"]) >= 95                 # 10 s at 10 Hz
    # the headline: noise and admitted smearing only (0.55 nT at the default 1000 / 10 / 2; over 8 seeds
    # of a hand rotation median 0.39, max 0.43 measured, against 0.43 / 0.57 at the former 2000 / 20 / 5)
    assert r["ptp_cal"] <= spin_ptp_bound(r["world"].scenario, len(r["spin_f_cal"])), r["ptp_cal"]
    # uncalibrated (nominal scale) the same spin is off by the sensor's axes and gains: the
    # simulation is seeded, so it is the benchmark's figure (543.5 nT, one decimal, in the docs),
    # to its rounding and to the interpreter's float over the field (the block averages of codes the
    # firmware streams: 4 half-ulps, as tests/test_shared_on_micropython.py bounds |h_c|)
    field = r["world"].scenario.field_nT
    assert abs(r["ptp_raw"] - UNCALIBRATED_PTP_NT) <= 0.05 + 4 * float_eps(name) * field, r["ptp_raw"]
    st = r["status"]
    assert st["overflow"] == 0 and st["badsync"] == 0 and st["gaps"] == 0
    # gc.mem_free of the heap the runner gave this interpreter, the firmware in it: some left, not all
    assert 0 < st["mem_free"] < heap_bytes(name), st["mem_free"]


def _device(tmp_path, motion, seconds, **cfg):
    return configured(tmp_path, motion, seconds, **cfg)


def _last_cal(w):
    return [e for e in events(w, "cal") if e.get("state") != "collecting"][-1]


def test_failed_calibrations_keep_the_previous_one(tmp_path):
    w, dev = _device(tmp_path, "hand", 45.0)
    w.press(0.2)
    dev.run_until(25.0)
    assert _last_cal(w)["state"] == "done"
    w.send(b"get-cal\n")
    dev.run_until(25.1)
    before = json.loads(w.lines()[-1])["cal"]
    # 1. finished by command after half a second: about half a turn puts the samples near
    #    one circle. Either the solve finds the ellipsoid unconstrained (degenerate_coverage:
    #    predicted error > 1 % of the field) or, when the shape prior carries it, the check
    #    finds no third dimension in the scatter (poor_observability); which one depends on
    #    the arc. Never a data-quality reason, never accepted. (A full one, asked for by
    #    command: with a calibration in force the button's press would make it quick, 1b.)
    w.send(b"start-cal full\n")
    dev.run_until(w.time + 0.5)
    w.send(b"finish-cal\n")
    dev.run_until(w.time + 0.1)
    res = _last_cal(w)
    assert res["state"] == "failed" and res["reason"] in ("degenerate_coverage", "poor_observability"), res
    assert res["n"] < 60 and ("rotate" in res["msg"] or "coverage" in res["msg"]), res
    # 1b. the same half turn from the button: with a calibration in force and partial coverage
    #     it ends as a quick re-calibration, which nothing has drifted for: the previous stays
    w.press(0.2)
    dev.run_until(w.time + 0.5)
    w.send(b"finish-cal\n")
    dev.run_until(w.time + 0.1)
    res = _last_cal(w)
    assert res["state"] == "failed" and res["reason"] == "not_better", res
    assert "it stays" in res["msg"]
    # 2. the operator configured the wrong local field: the fit is fine, the check refuses it
    w.send(b"config set field_nt 30000\n")
    dev.run_until(w.time + 0.1)
    w.press(0.2)
    dev.run_until(44.0)                   # auto-finish once ready
    res = _last_cal(w)
    assert res["state"] == "failed" and res["reason"] == "field_out_of_range" and res["n"] > 500, res
    w.send(b"get-cal\nstatus\n")
    dev.run_until(44.2)
    after = json.loads(w.lines()[-2])["cal"]
    assert after == before
    status = json.loads(w.lines()[-1])
    assert status["calibrated"] and status["last_cal"]["reason"] == "field_out_of_range"
    assert status["cal_source"] == "new"       # still the first calibration of this power-up
    dev.close()


def _out_of_memory(*args):
    raise MemoryError("memory allocation failed, allocating 1280 bytes")


def test_a_start_or_finish_the_heap_cannot_hold_is_refused_no_memory_and_the_calibration_stays(tmp_path, monkeypatch):
    """A board whose heap is in pieces (the .mpy firmware's: docs/limits.md) may fail an allocation
    at a session's start or its finish. Each is a failed `cal` with reason no_memory, the LED's
    FAILED pattern and then the steady one (not "collecting" for a session that no longer runs),
    the calibration in force kept, and the next session runs as usual."""
    import calibration_flow
    import led
    w, dev = _device(tmp_path, "hand", 60.0)
    w.press(0.2)
    dev.run_until(25.0)
    assert _last_cal(w)["state"] == "done"
    before = dev.app.flow.cal.to_dict()
    for finish_by in ("command", "button"):
        w.send(b"start-cal full\n")
        dev.run_until(w.time + 3.0)
        monkeypatch.setattr(dev.app.flow.session, "finish", _out_of_memory)
        if finish_by == "command":
            reply = ask(w, dev, "finish-cal", dt=0.1)
            assert reply["ok"] and reply["result"]["reason"] == "no_memory", reply
        else:
            w.press(0.2)
            dev.run_until(w.time + 0.3)
        res = _last_cal(w)
        assert (res["state"], res["reason"]) == ("failed", "no_memory") and "in force" in res["msg"], res
        assert dev.app.flow.session is None and dev.app.flow.cal.to_dict() == before
        assert dev.app.led._pattern == led.FAILED and dev.app.led.base == led.SURVEY
    # the start: a press refused with its reason and the LED's FAILED pattern, nothing left half made
    monkeypatch.setattr(calibration_flow, "array", _out_of_memory)
    w.press(0.2)
    dev.run_until(w.time + 0.3)
    res = _last_cal(w)
    assert (res["state"], res["reason"]) == ("failed", "no_memory") and "in force" in res["msg"], res
    assert dev.app.flow.session is None and dev.app.output.session is None and dev.app.led.base == led.SURVEY
    assert ask(w, dev, "start-cal full")["error"] == "no_memory"
    monkeypatch.undo()
    assert ask(w, dev, "start-cal full")["ok"]
    w.send(b"cancel-cal\n")
    dev.run_until(w.time + 0.3)
    assert dev.app.flow.cal.to_dict() == before
    dev.close()


def test_wrong_local_field_is_refused_with_its_reason(tmp_path):
    w, dev = _device(tmp_path, "hand", 30.0, field_nt=30000.0)
    w.press(0.2)
    dev.run_until(29.0)
    res = _last_cal(w)
    assert res["state"] == "failed" and res["reason"] == "field_out_of_range"
    assert "configured 30000" in res["msg"]
    assert dev.app.flow.cal is None and not os.path.exists(tmp_path / "flash" / "cal.json")
    dev.close()


def test_single_axis_spin_cannot_calibrate(tmp_path):
    """A rotation about one axis only leaves the ellipsoid undetermined: refused, with a reason."""
    w, dev = _device(tmp_path, "spin", 25.0, max_cal_s=20)
    w.press(0.2)
    dev.run_until(24.0)
    res = _last_cal(w)
    assert res["state"] == codes.FAILED
    assert res["reason"] in (codes.DEGENERATE_COVERAGE, codes.POOR_OBSERVABILITY, codes.PREDICTED_ERROR_TOO_HIGH)
    dev.close()


def test_long_press_cancels_and_led_shows_states(tmp_path):
    w, dev = _device(tmp_path, "hand", 10.0, auto_finish=False)
    w.press(0.2)
    dev.run_until(3.0)
    collecting = [lv for t, lv in w.led_log if 1.0 < t < 3.0]
    # 2 Hz blink (250/250 ms): 8 edges in 2 s; the loop updates the LED at least every 20 ms,
    # so an edge near either end of the window may fall outside it
    assert 7 <= len(collecting) <= 9
    w.press(2.0)                                      # long press: cancel fires while held
    dev.run_until(6.0)
    res = _last_cal(w)
    assert res["state"] == "cancelled"
    assert dev.app.flow.session is None and dev.app.flow.cal is None
    dev.close()


# A passing vehicle: 300 A m^2 (a car) 4 m away at 20 m/s (desktop.sim.field.Field).
# Its field mu0/4pi m k / r^3 (k = 1..2 with the angle) exceeds the 50 nT gate for
# r < (100 * 300 * k / 50)^(1/3) = 8.4..10.6 m: for 2 sqrt(r^2 - 4^2) / 20 m/s =
# 0.74..0.98 s, 74..98 samples at the default 100 samples/s.
CAR = {"moment_Am2": (0.0, 0.0, 300.0), "distance_m": 4.0, "speed_m_s": 20.0, "t_closest_s": 15.0}


def test_passing_dipole_is_gated_and_calibration_stays_in_spec(tmp_path):
    r = calibrate_and_verify(kind="cpython", root=str(tmp_path), rotate_s=30.0, spin_s=10.0,
                             auto_finish=False, cal_world={"dipole": CAR})
    cal, p = r["cal"], r["last_progress"]
    assert cal["state"] == "done", cal
    # the gate sees the samples above 50 nT (up to 24 % of them fail the rate gate
    # first, docs/simulator.md) and the back-off holds through the 1/r^3 tail
    assert p["rej_dist"] + p["removed"] >= 0.5 * 74, p
    assert p["removed"] > 0                           # the onset had gone in and came out again
    # the headline level, despite ~1000 nT at closest approach
    assert r["ptp_cal"] <= spin_ptp_bound(r["world"].scenario, len(r["spin_f_cal"])), r["ptp_cal"]


def test_dipole_before_any_provisional_fit_fails_and_keeps_the_previous_calibration(tmp_path):
    """Before the first provisional solve nothing can be gated: the car goes into the fit,
    the residual check refuses it, and the calibration from before stays in force."""
    car = dict(CAR, moment_Am2=(0.0, 0.0, 1000.0), t_closest_s=17.0)
    w = make_world(serial=None, motion="hand", seconds=32.0, seed=4, motion_seed=5, rate=2000, dipole=car)
    write_config(str(tmp_path), **handheld_config(w.scenario))
    dev = start_device(w, str(tmp_path), kind="cpython")
    dev.run_until(0.5)
    w.press(0.2)
    dev.run_until(14.0)                               # the first calibration auto-finishes in ~11 s
    assert _last_cal(w)["state"] == "done"
    before = dev.app.flow.cal.to_dict()
    w.press(0.2)                                      # second calibration, the car passes 3 s in
    dev.run_until(28.0)
    w.press(0.2)
    dev.run_until(29.0)
    res = _last_cal(w)
    assert res["state"] == "failed" and res["reason"] == "rms_too_high", res
    assert dev.app.flow.cal.to_dict() == before
    dev.close()


@pytest.mark.parametrize("die_c, warned", [(31.0, True), (28.0, False)])
def test_survey_warns_when_the_temperature_left_the_calibration_temperature(tmp_path, die_c, warned):
    """Calibrated at 25 C, temp_warn_c 5 (default). The die sensor reads to ~0.02 C
    (7 uV ADC noise over 490 uV/C, [DS] §8.3.2.4), so 6 C warns and 3 C does not."""
    from shared.calibration import Calibration
    w = make_world(serial=None, motion="stationary", seconds=4.0, seed=4, rate=2000, temp_c=die_c)
    write_config(str(tmp_path), **handheld_config(w.scenario))
    dev = start_device(w, str(tmp_path), kind="cpython")
    dev.run_until(0.5)
    k = float(w.scenario.nt_per_code()[0])
    cal = Calibration([[k, 0, 0], [0, k, 0], [0, 0, k]], [0, 0, 0], w.scenario.field_nT, meta={"temperature_c": 25.0})
    w.send(b"set-cal " + json.dumps(cal.to_dict()).encode() + b"\nstream corrected\n")
    dev.run_until(2.0)
    data = events(w, "data")
    assert len(data) >= 10
    # the die's own reading (0.015 C rms at 2000 SPS: 7.3 uV over 490 uV/C): 0.5 C is a tenth of the
    # 5 C warning step this test is about, and 30 sd of the read noise (measured 0.02-0.05 C)
    assert all(abs(d["temp"] - die_c) < 0.5 for d in data)
    if warned:
        assert all(d["warn"] and "differs from calibration 25.0 C" in d["warn"] for d in data)
    else:
        assert all(d["warn"] is None for d in data)
    w.send(b"status\n")
    dev.run_until(2.2)
    assert [d for d in events(w) if "temp_warn" in d][-1]["temp_warn"] is warned
    dev.close()


# The widened predicted error's correlation time (shared/honest.py) compares batch means of the
# residuals, ~0.04 nT apart for white 1 nT noise in 512-sample batches. A calibration solved in
# 30-bit floats (22-bit significands) differs from the double one by a few ulps of its matrix,
# which move |h_c| by 0.01-0.05 nT of 50,000, differently by orientation: with it the batch
# means, so the estimate, by up to ~10 %, and the error by ~5 % (measured 4 %).
_BATCH_KEYS = ("predicted_error", "tau_int")


def _same(a, b, eps, path="line"):
    """JSON values equal; floats to the narrower interpreter's rounding (4 half-ulps relative,
    or one unit of the decimals the firmware rounds them to; _BATCH_KEYS on floats narrower
    than 32 bits to 10 %)."""
    if isinstance(a, float) or isinstance(b, float):
        tol = max(4 * eps * abs(a), 10.0 ** -3 if eps > 1e-10 else 0.0)
        if eps > 2.0 ** -24 and path.rsplit(".", 1)[-1] in _BATCH_KEYS:
            tol = max(tol, 0.1 * abs(a))
        assert isinstance(b, (int, float)) and abs(a - b) <= tol, (path, a, b)
    elif isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), (path, a, b)
        for k in a:
            _same(a[k], b[k], eps, path + "." + k)
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), (path, a, b)
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, eps, "%s[%d]" % (path, i))
    else:
        assert a == b, (path, a, b)


@pytest.mark.parametrize("name", INTERPRETERS)
def test_cpython_and_each_interpreter_run_the_same_run(name, tmp_path):
    """The in-process runner and the pipe runner drive the same firmware through the same
    sequence of events: 12 s of streaming raw blocks while calibrating give the same JSON
    lines, every integer and string equal, floats value for value in double and to the
    float width elsewhere (the samples the gates accept are the same on every interpreter)."""
    need(name)
    lines = {}
    for kind in ("cpython", name):
        root = str(tmp_path / kind)
        w = make_world(serial=None, motion="hand", seconds=14.0, seed=2, motion_seed=21)
        write_config(root, **handheld_config(w.scenario), stream="raw")
        dev = start_device(w, root, kind=kind)
        try:
            dev.run_until(0.5)
            w.press(0.2)
            dev.run_until(12.5)
        finally:
            dev.close()
        lines[kind] = [json.loads(ln) for ln in w.lines()]
    a, b = lines["cpython"], lines[name]
    assert len(a) > 100 and [e.get("ev") for e in a].count("cal") > 10
    if name == "micropython":
        assert a == b
    else:
        _same(a, b, float_eps(name))


def test_start_cal_kinds_are_checked(tmp_path):
    """start-cal quick needs a calibration in force; an unknown kind is a bad argument;
    the reply says which kind runs (docs/protocol.md, calibration kinds)."""
    w, dev = _device(tmp_path, "hand", 5.0)
    try:
        for line, code in ((b"start-cal quick\n", "no_calibration"), (b"start-cal sideways\n", "bad_argument")):
            w.send(line)
            dev.run_until(w.time + 0.2)
            reply = json.loads(w.lines()[-1])
            assert reply["ok"] is False and reply["error"] == code, reply
        w.send(b"start-cal\n")
        dev.run_until(w.time + 0.2)
        reply = [json.loads(x) for x in w.lines() if '"cmd": "start-cal"' in x][-1]
        assert reply["ok"] and reply["kind"] == "full"      # nothing in force: auto is a full one
    finally:
        dev.close()


@pytest.mark.parametrize("die_c, warned, applied_c", [(24.0, False, 24.0), (26.5, True, 26.5), (60.0, True, 35.0)])
def test_compensation_warns_outside_its_range_and_holds_far_outside(tmp_path, die_c, warned, applied_c):
    """A calibration with temperature coefficients measured over 15..25 C: the survey applies
    them at the die temperature, warns more than 1 C outside the range, and beyond 10 C
    outside holds them at the edge (a die reading of 60 C is corrected as 35 C). Checked on
    the streamed vectors against Calibration.at_temperature of the same record: the same to
    the firmware's rounding of its output (3 decimals) and the block's averaging of codes."""
    from shared.calibration import Calibration
    w = make_world(serial=None, motion="stationary", seconds=4.0, seed=4, rate=2000, temp_c=die_c)
    write_config(str(tmp_path), **handheld_config(w.scenario))
    dev = start_device(w, str(tmp_path), kind="cpython")
    try:
        dev.run_until(0.5)
        k = float(w.scenario.nt_per_code()[0])
        tc = {"t0_c": 20.0, "offset_per_c": [40.0, -25.0, 10.0], "gain_per_c": [2e-5, -1e-5, 3e-5],
              "range_c": [15.0, 25.0], "sources": 2, "method": "calibrations"}
        cal = Calibration([[k, 0, 0], [0, k, 0], [0, 0, k]], [0, 0, 0], w.scenario.field_nT,
                          meta={"temperature_c": 20.0}, tempco=tc)
        w.send(b"set-cal " + json.dumps(cal.to_dict()).encode() + b"\nstream corrected\n")
        dev.run_until(2.0)
        data = events(w, "data")[-5:]
        assert len(data) == 5
        for d in data:
            assert bool(d["warn"]) is warned and (not warned or "outside the compensated 15.0..25.0 C" in d["warn"])
            expect = cal.at_temperature(applied_c).correct(*d["c"])
            # the die reads to ~0.02 C: at these coefficients (40 codes/C, k = 0.0144 nT/code)
            # 0.02 C moves b by 0.012 nT; the output is rounded to 0.001 nT
            assert max(abs(a - b) for a, b in zip(d["b"], expect)) < 0.05, (d["b"], expect)
            if applied_c != die_c:
                wrong = cal.at_temperature(die_c).correct(*d["c"])
                # the coefficients at the die's own reading instead (60 C, 25 C further): 40 codes/C
                # x 0.0144 nT/code x 25 C moves b_x by 14 nT; 1 nT is far from both that and 0
                assert max(abs(a - b) for a, b in zip(d["b"], wrong)) > 1.0
    finally:
        dev.close()
