"""A re-probed ADC is cleared at the first health check after the re-probe, and only then (device/health.py).

A re-probe (reset, ID, registers, RDATAC) passes on a chip whose DRDY is stuck or whose
frames are corrupt: the registers answer. So the fault is cleared only when a check
period (health.CHECK_MS) after the re-probe has seen conversions with good headers:
- while the fault lasts, re-probes come and go and no `cleared` event is ever sent;
- once it is gone, the chip's samples flow again from the re-probe on (the firmware
  streams them while it verifies: `stream raw`), and the `cleared` event comes one check
  period later:
  not at the re-probe (zero checks), not a check later than the first.
Times are the firmware's (ticks_ms: its events' "t"), observed every STEP_S of the world.
"""

import contextlib
import json

import pytest

from desktop.firmware.files import import_device
from tests.device_session import ask, boot

HEALTH = import_device("health")
CHECK_S = HEALTH.CHECK_MS / 1000
REPROBE_S = HEALTH.REPROBE_MS / 1000
STEP_S = 0.01
# a check runs in the first main-loop pass at or after CHECK_MS (a pass per 20 ms of
# conversions, plus the passes' own cost): two passes of slack
PASS_SLACK_S = 0.04

PROBE_PASSING = [
    # (chip, emulator fault, rate): the chip's registers answer a probe, its conversions do not come
    (0, "drdy-stuck-high", None),
    (0, "drdy-stuck-low", None),
    (1, "status-corrupt", 1.0),
]


def run_logged(w, dev, seconds):
    """Run `seconds` in STEP_S steps; the JSON lines printed, each with the world's time it was seen at."""
    out = []
    end = w.time + seconds
    while w.time < end:
        mark = len(w.lines())
        dev.run_until(w.time + STEP_S)
        out += [(w.time, json.loads(x)) for x in w.lines()[mark:]]
    return out


def cleared(log):
    return [(t, d) for t, d in log if d.get("ev") == "fault" and d.get("code") is None]


@contextlib.contextmanager
def faulty(tmp_path, chip, fault, rate):
    """A still handheld streaming raw samples whose chip `chip` has just taken `fault`."""
    w, dev = boot(tmp_path, seed=12)
    try:
        ask(w, dev, "stream raw", dt=0.5)
        w.handheld.set_fault(chip, fault, rate)
        yield w, dev
    finally:
        dev.close()


@pytest.mark.parametrize("chip, fault, rate", PROBE_PASSING, ids=[f[1] for f in PROBE_PASSING])
def test_a_fault_that_passes_the_probe_is_never_cleared_while_it_lasts(tmp_path, chip, fault, rate):
    with faulty(tmp_path, chip, fault, rate) as (w, dev):
        # the fault named, then three re-probe intervals (the interval only grows)
        log = run_logged(w, dev, 1.0 + 3 * REPROBE_S + CHECK_S)
        faults = [d for _, d in log if d.get("ev") == "fault"]
        assert faults and faults[0]["code"], faults
        assert not cleared(log), faults
        assert ask(w, dev, "status")["state"] == "fault"


@pytest.mark.parametrize("chip, fault, rate", PROBE_PASSING, ids=[f[1] for f in PROBE_PASSING])
def test_a_recovered_chip_is_cleared_one_check_after_its_reprobe(tmp_path, chip, fault, rate):
    with faulty(tmp_path, chip, fault, rate) as (w, dev):
        run_logged(w, dev, 1.0)
        assert ask(w, dev, "status")["state"] == "fault"
        w.handheld.set_fault(chip, None)
        log = run_logged(w, dev, 2 * REPROBE_S + 2 * CHECK_S)   # the next re-probe, then its check
        done = cleared(log)
        assert len(done) == 1, [d for _, d in log if d.get("ev") == "fault"]
        t_cleared = done[0][0]
        raw = [d["t"] / 1000.0 for _, d in log if d.get("ev") == "raw"]
        first, period = raw[0], max(b - a for a, b in zip(raw[:4], raw[1:4]))
        # the first raw sample comes within a sample period of the re-probe; the clearing at
        # re-probe + CHECK_S (+ the pass it runs in): so it follows that sample by CHECK_S less
        # a period at least (0 with a clearing at the re-probe), by 2 CHECK_S less a period
        # were it a check late
        gap = t_cleared - first
        assert CHECK_S - period - STEP_S <= gap <= CHECK_S + PASS_SLACK_S + STEP_S, (raw[:4], t_cleared)
        assert ask(w, dev, "status")["state"] == "survey"
