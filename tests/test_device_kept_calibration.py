"""A full calibration made with the button alone that is predicted no better than the one in force
does not replace it: the one in force stays, the LED shows KEPT_PREVIOUS, the `cal` event and
status's last_cal say `worse_than_current` with both figures, and keep-cal puts the new one in force
after all (device/calibration_flow.py). status's last_cal says whether its calibration is in force,
and what replaced it since (keep-cal, set-cal, clear-cal)."""

import json

import pytest

from desktop.cli.status import last_cal_line
from tests.device_session import ask, events
from tests.interpreters import need


def _final(w):
    return [e for e in events(w, "cal") if e.get("state") != "collecting"][-1]


def _kept_previous_on_led(led_log, since):
    """device/led.py's KEPT_PREVIOUS after `since`: an on-pulse of 1.1-1.3 s, then three short blinks."""
    on = [(t0, t1 - t0) for (t0, lv), (t1, _) in zip(led_log, led_log[1:]) if lv and t0 >= since]
    for i, (t0, d) in enumerate(on[:-3]):
        if 1.1 < d < 1.3 and all(0.05 < dd < 0.15 for _, dd in on[i + 1:i + 4]):
            return True
    return False


def _handheld(tmp_path, kind, **cfg):
    """tests/device_session.py's configured() on `kind`: the firmware in this process or on an interpreter."""
    from desktop.devicesim.procedure import handheld_config
    from desktop.devicesim.runners import start_device, write_config
    from desktop.devicesim.world import make_world

    w = make_world(serial=None, motion="hand", seconds=60.0, seed=4, motion_seed=5, rate=2000)
    write_config(str(tmp_path), **handheld_config(w.scenario), **cfg)
    dev = start_device(w, str(tmp_path), kind=kind)
    dev.run_until(0.5)
    return w, dev


@pytest.mark.parametrize("kind", ["cpython", "micropython"])
def test_a_worse_button_calibration_keeps_the_one_in_force(tmp_path, kind):
    if kind != "cpython":
        need(kind)
    # min_coverage 0.1: the button's press (auto) ends full after a short turn, as an operator
    # in a hurry makes it; the session waits for the second press (auto_finish off)
    w, dev = _handheld(tmp_path, kind, min_coverage=0.1, auto_finish=False)
    ask(w, dev, "start-cal full hold")
    dev.run_until(40.0)
    first = ask(w, dev, "finish-cal", dt=2.0)["result"]
    assert first["state"] == "done" and first["in_force"] is True, first
    before = ask(w, dev, "get-cal")["cal"]
    # five seconds of turning: a full calibration with a third of the samples
    w.press(0.2)
    dev.run_until(w.time + 5.0)
    pressed = w.time
    w.press(0.2)
    dev.run_until(w.time + 3.0)
    res = _final(w)
    assert res["state"] == "failed" and res["reason"] == "worse_than_current" and res["kind"] == "full", res
    assert res["in_force"] is False and res["predicted_error"] > first["predicted_error"], res
    assert "%.3f nT" % res["predicted_error"] in res["msg"] and "it stays" in res["msg"], res
    assert _kept_previous_on_led(w.led_log, pressed)
    assert ask(w, dev, "get-cal")["cal"] == before            # the better one is in force
    st = ask(w, dev, "status")
    assert st["last_cal"]["reason"] == "worse_than_current" and st["last_cal"]["in_force"] is False
    # the operator wants the new one after all (fluxcal calibrate --replace does this)
    assert ask(w, dev, "keep-cal")["saved"] is True
    now = ask(w, dev, "get-cal")["cal"]
    assert round(now["diagnostics"]["predicted_error"], 4) == res["predicted_error"]   # the event rounds to 4
    st = ask(w, dev, "status")
    assert st["last_cal"]["in_force"] is True and st["last_cal"]["since"] == "keep-cal", st["last_cal"]
    again = ask(w, dev, "keep-cal")
    assert again["ok"] is False and again["error"] == "no_calibration", again
    # the previous one sent back (what push-cal does): last_cal no longer names what is in force
    assert ask(w, dev, "set-cal " + json.dumps(before), dt=1.0)["ok"] is True
    st = ask(w, dev, "status")
    assert st["last_cal"]["in_force"] is False and st["last_cal"]["since"] == "set-cal", st["last_cal"]
    line = last_cal_line(st["last_cal"])        # fluxcal status's line
    assert line.startswith("last calibration since boot: failed (worse_than_current)") and \
        line.endswith("replaced since by a calibration sent with set-cal (fluxcal push-cal, calibrate): not in force")
    dev.close()
