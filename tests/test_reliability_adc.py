"""ADC faults after boot (docs/reliability.md): named, survived, recovered, the calibration kept.

The emulated chips take a fault at run time (desktop/sim/handheld.py set_fault);
the firmware must say which (status `state: fault`, `fault_code`, a `fault`
event), stop the survey output and refuse a calibration while it lasts, re-probe
by itself, resume when the fault clears, and never touch the calibration.
"""

import json

import pytest

from desktop.devicesim.runners import start_device
from desktop.devicesim.world import make_world
from desktop.firmware.files import import_device
from tests.device_session import ask, boot, events

K = import_device("config").SCHEMA["scale_x"][0]
GOOD = {"matrix": [[K, 0, 0], [0, K, 0], [0, 0, K]], "offset": [0, 0, 0], "field": 48000.0}
REPROBE_S = import_device("health").REPROBE_MS / 1000


FAULTS = [
    # (chip, emulator fault, rate, the code the firmware names it by)
    (1, "absent-0x00", None, "adc_silent"),
    (1, "absent-0xff", None, "adc_all_ones"),
    (0, "drdy-stuck-high", None, "adc_no_drdy"),
    (0, "drdy-stuck-low", None, "adc_no_drdy"),
    (0, "status-corrupt", 1.0, "adc_bad_headers"),
]


@pytest.mark.parametrize("chip, fault, rate, code", FAULTS, ids=[f[1] for f in FAULTS])
def test_a_fault_after_boot_is_named_refused_and_recovered(tmp_path, chip, fault, rate, code):
    w, dev = boot(tmp_path, seed=12)
    try:
        assert ask(w, dev, "set-cal " + json.dumps(GOOD))["ok"]
        ask(w, dev, "stream corrected", dt=1.0)
        mark = len(w.lines())
        w.handheld.set_fault(chip, fault, rate)
        dev.run_until(w.time + 1.0)                    # a check every 250 ms, DRDY deadline 100 ms
        s = ask(w, dev, "status")
        assert s["state"] == "fault" and s["fault_code"] == code and s["calibrated"], s
        ev = events(w, "fault", mark)
        assert ev and ev[0]["code"] == code and ev[0]["msg"]
        r = ask(w, dev, "start-cal")
        assert not r["ok"] and r["error"] == "fault" and code in r["msg"]
        quiet = len(w.lines())
        dev.run_until(w.time + 2 * REPROBE_S + 0.5)   # still faulty: re-probed, still named
        assert not events(w, "data", quiet)
        assert ask(w, dev, "status")["state"] == "fault"

        w.handheld.set_fault(chip, None)               # the fault clears: resumes by itself
        mark = len(w.lines())
        dev.run_until(w.time + REPROBE_S * 4 + 1.0)    # the re-probe interval may have doubled once
        s = ask(w, dev, "status")
        assert s["state"] == "survey" and s["fault"] is None and s["adc_faults"] >= 1, s
        assert any(e["code"] is None and e["cleared"] for e in events(w, "fault", mark))
        assert len(events(w, "data", mark)) > 5
        assert ask(w, dev, "get-cal")["cal"]["field"] == 48000.0    # the calibration kept throughout
    finally:
        dev.close()


def test_a_fault_during_calibration_cancels_it_and_keeps_the_previous(tmp_path):
    w, dev = boot(tmp_path, seed=12, motion="hand")
    try:
        assert ask(w, dev, "set-cal " + json.dumps(GOOD))["ok"]
        assert ask(w, dev, "start-cal")["ok"]
        dev.run_until(w.time + 3.0)
        w.handheld.set_fault(1, "absent-0x00")
        dev.run_until(w.time + 1.0)
        res = [e for e in events(w, "cal") if e["state"] != "collecting"][-1]
        assert res["state"] == "cancelled" and res["reason"] == "fault" and "stopped answering" in res["msg"]
        assert ask(w, dev, "get-cal")["cal"]["field"] == 48000.0
    finally:
        dev.close()


def test_a_fault_at_boot_clears_without_a_reboot_on_micropython(tmp_path):
    """At boot chip 1 does not answer; it is plugged back: the firmware re-probes and resumes."""
    w = make_world(serial=None, motion="stationary", seconds=20.0, seed=13, fault=(None, "absent-0x00"))
    dev = start_device(w, str(tmp_path), kind="micropython")
    try:
        dev.run_until(0.5)
        s = ask(w, dev, "status")
        assert s["state"] == "fault" and s["fault_code"] == "adc_probe" and "#1" in s["fault"]
        w.handheld.set_fault(1, None)
        dev.run_until(w.time + REPROBE_S + 1.0)
        s = ask(w, dev, "status")
        assert s["state"] == "survey" and s["samples"] > 0, s
    finally:
        dev.close()
