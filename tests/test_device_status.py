"""The `status` reply's keys, pinned: every owner of the firmware's state contributes its part
(the acquisition, the ADC supervisor, the boot guard, the output, the calibration flow) and the
status command merges them, so a part dropped or renamed in a refactor fails here, not on a
user's laptop (docs/protocol.md lists the keys for users; desktop/cli reads them).

The sets were taken from the firmware as it was before its state was split among those owners.
"""

import os
import re

from tests.device_session import ask, boot
from tests.docs_index import ROOT

# in every reply, whatever the state
ALWAYS = {"v", "ok", "cmd", "state", "fault", "fault_code", "safe_mode", "errors", "last_error", "calibrated",
          "cal_source", "cal_problem", "config_problems", "stream", "uptime_ms", "temp", "temp_warn", "cal_kind",
          "tempco_range", "last_cal", "frames", "overflow", "missed", "badsync", "discarded", "gaps", "samples",
          "spikes", "clipped", "screen", "delag_us", "delag", "sums", "linalg", "magnitude", "drdy", "drdy_counter", "reader", "sample",
          "unfinished_boots",
          "watchdog_reset", "watchdog_ms", "button"}
# the ADC's run-time health exists once the chips answered at boot
HEALTH = {"adc_faults"}
# a calibration in progress: its progress report
PROGRESS = {"state", "kind", "gate_dps", "slow_down", "n", "seen", "coverage", "pred_nt", "rej_rate", "rej_dist",
            "rej_cap", "removed", "clipped", "ready", "dir", "hold", "gates"}


def test_survey_reply(tmp_path):
    w, dev = boot(tmp_path)
    try:
        s = ask(w, dev, "status")
        assert set(s) == ALWAYS | HEALTH
        assert (s["state"], s["fault"], s["calibrated"], s["stream"], s["errors"]) == ("survey", None, False, "off", 0)
        assert (s["sums"], s["linalg"]) == ("python", "python")    # CPython loads no native module
        assert s["drdy"] == "python"     # ... and the simulator's HAL has no drdy_bus
        assert s["drdy_counter"] is None  # ... nor a counter of DRDY (rp2's PIO)
        assert s["screen"] == "python"   # ... nor the spike screen's push
        assert s["delag"] == "python"    # ... nor the de-lag's
        assert (s["reader"], s["sample"]) == ("python", "python")   # ... nor the ring's reader, the output's sample
        assert s["magnitude"] is None    # no calibration in force: no |h_c|
        assert s["button"] == "polled"   # the simulator's HAL times no closing by an interrupt
        assert s["samples"] > 0 and s["frames"] > s["samples"]   # decimated: fewer samples than frames
    finally:
        dev.close()


def test_calibrating_and_logging_reply(tmp_path):
    w, dev = boot(tmp_path)
    try:
        assert ask(w, dev, "config set log true")["ok"]
        assert ask(w, dev, "start-cal")["ok"]
        s = ask(w, dev, "status")
        assert set(s) == ALWAYS | HEALTH | {"cal", "log"}
        assert s["state"] == "calibrating" and set(s["cal"]) == PROGRESS and s["cal"]["state"] == "collecting"
        assert s["cal"]["gates"] == "python"     # CPython loads no native module
        assert set(s["log"]) == {"lines", "error"} and s["log"]["error"] is None
        assert ask(w, dev, "cancel-cal")["ok"]
        s = ask(w, dev, "status")
        assert set(s) == ALWAYS | HEALTH | {"log"}
        assert s["state"] == "survey" and s["last_cal"]["state"] == "cancelled"
    finally:
        dev.close()


def test_fault_at_boot_reply(tmp_path):
    """A chip that never answered: no run-time health yet (it starts once the chips answer)."""
    w, dev = boot(tmp_path, fault=(None, "absent-0x00"))
    try:
        s = ask(w, dev, "status")
        assert set(s) == ALWAYS
        assert (s["state"], s["fault_code"], s["temp"]) == ("fault", "adc_probe", None)
    finally:
        dev.close()


def test_a_board_adds_its_free_heap(tmp_path):
    """MicroPython and CircuitPython have gc.mem_free (the `micropython` executable here)."""
    w, dev = boot(tmp_path, kind="micropython")
    try:
        s = ask(w, dev, "status")
        assert set(s) == ALWAYS | HEALTH | {"mem_free"}
        assert isinstance(s["mem_free"], int)
        assert s["sums"] == "python"     # the simulated board's lib/ holds no fitsums.mpy
        assert (s["drdy"], s["reader"], s["sample"]) == ("python",) * 3     # ... nor drdy.mpy
    finally:
        dev.close()


def test_the_protocol_doc_names_every_status_key_and_no_other():
    """docs/protocol.md's "Status": the keys pinned above, each named there (a bullet's leading
    names, or the acquisition counters' paragraph), and none it names that status no longer sends;
    the progress report's keys in the `cal` event's description."""
    with open(os.path.join(ROOT, "docs", "protocol.md"), encoding="utf-8") as fh:
        doc = fh.read()
    section = doc.split("\n## Status\n", 1)[1].split("\n## ", 1)[0]
    named = set()
    for bullet in re.findall(r"^- (.*?)(?=^- |\Z)", section, re.M | re.S):
        if bullet.startswith("Acquisition counters"):    # a paragraph naming each: `name` (what it counts)
            named |= set(re.findall(r"`([a-z_]+)`\s+\(", bullet))
        else:                                             # a bullet's own fields: the names before its colon
            named |= set(re.findall(r"`([a-z_]+)`", bullet.split(":", 1)[0]))
    keys = (ALWAYS | HEALTH | {"cal", "log", "mem_free"}) - {"v", "ok", "cmd"}
    assert keys - named == set(), "status keys protocol.md leaves out: %s" % sorted(keys - named)
    assert named - keys == set(), "protocol.md names status keys the firmware does not send: %s" % sorted(named - keys)
    events = doc.split("\n## Events\n", 1)[1].split("\n## ", 1)[0]
    progress = events.split("- `cal`, progress", 1)[1].split("\n- `cal`, result", 1)[0]
    left_out = {k for k in PROGRESS if not re.search(r"`%s(`|: )" % k, progress)}
    assert left_out == set(), "cal progress keys protocol.md leaves out: %s" % sorted(left_out)
