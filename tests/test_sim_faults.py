"""Run-time fault injection in the ADS1292 emulator (docs/simulator.md, "Faults").

Every fault of FAULTS switched on mid-run and off again, on the emulator directly: what a
driver reads (registers, frames) and when DRDY falls, before, during and after. Conversions
are computed 512 at a time ahead of use (the firmware simulation's batch): a switch must
take effect at its tick all the same, so each session is run at batch 512 and batch 1 and
the byte streams compared, and the stretches before the switch and after the clear against
a chip that never had the fault. The clock-drift fault's DRDY ticks and data against the
slip its rate implies; the World's idle with a dead DRDY under the in-process firmware.
"""

import json

import numpy as np
import pytest

from desktop.sim.ads1292 import registers as A
from desktop.sim.ads1292.bus import SPIBus
from desktop.sim.ads1292.chip import FAULTS, ADS1292
from desktop.sim.ads1292.convert import NO_NOISE, convert

DR = 3                      # 1000 SPS: a conversion every 128 ticks (the firmware's default)
D = A.DECIMATION[DR]
REGS = A.standard_registers(dr=DR, gain=1, mux=(A.MUX_NORMAL, A.MUX_TEMP))
GRID_HZ = 16000
DEAD = ("absent-0x00", "absent-0xff", "drdy-stuck-high", "drdy-stuck-low")
# a rate that shows in a few dozen frames, for the faults that draw
RATES = {"status-corrupt": 1.0, "bit-flips": 0.05, "clock-drift": 0.005}


def volts(seconds=3.0, seed=7):
    t = np.arange(int(seconds * GRID_HZ)) / GRID_HZ
    rng = np.random.default_rng(seed)
    return np.c_[0.2 * np.sin(2 * np.pi * 3 * t) + 0.05 * t, 1e-3 * rng.standard_normal(t.size)]


def cmd(chip, *data):
    chip.select(True)
    out = chip.transfer(list(data))
    chip.select(False)
    return out


def probe(chip):
    """What the firmware does to (re)start a chip: SDATAC, read ID, write the map, read it back,
    RDATAC, START. Returns (ID, the map read back)."""
    cmd(chip, A.SDATAC)
    chip_id = cmd(chip, A.RREG | A.ID, 0, 0)[2]
    cmd(chip, A.WREG | A.CONFIG1, 10, *REGS[1:12])
    back = list(cmd(chip, A.RREG | A.CONFIG1, 10, *([0] * 11))[2:])
    cmd(chip, A.RDATAC)
    cmd(chip, A.START)
    return chip_id, back


def reprobe(chip):
    """The probe, then the first DRDY after its START: (ID, map read back, that DRDY's tick)."""
    found = probe(chip)
    chip.wait_drdy(0.01)
    return found + (chip.tick,)


def started(batch, seed=3, noise=True, **kw):
    chip = ADS1292(seed=seed, batch=batch, noise=noise, **kw)
    chip.load(volts(), GRID_HZ)
    chip.advance(0.05)                        # past tPOR
    chip_id, back = probe(chip)
    assert chip_id == 0x53 and back == REGS[1:12] and chip.violations == []
    chip.wait_drdy(0.01)                      # past the settling time: a DRDY every 1 ms from here
    return chip


def frames(chip, k, timeout=0.0015):
    """k waits for DRDY (each at most `timeout`), each followed by a 9-byte read (RDATAC):
    [(DRDY tick or None, falls, the pin after the read, frame bytes)]."""
    out = []
    for _ in range(k):
        try:
            chip.wait_drdy(timeout)
            tick = chip.tick
        except TimeoutError:
            tick = None
        chip.select(True)
        data = chip.transfer(bytes(9))
        chip.select(False)
        out.append((tick, chip.drdy_falls, chip.drdy, data))
    return out


def session(fault, batch, switch=True):
    """60 frames clean, `fault` switched on for 60, cleared (then a re-probe), 60 more."""
    chip = started(batch)
    seen = [frames(chip, 60)]
    on_tick = chip.tick
    if switch:
        chip.set_fault(fault, RATES.get(fault))
        assert chip.fault == fault
    seen.append(frames(chip, 60))
    off_tick = chip.tick
    if switch:
        chip.set_fault(None)
        assert chip.fault is None
    seen.append(reprobe(chip) if fault in DEAD else None)
    seen.append(frames(chip, 60))
    return chip, seen, on_tick, off_tick


@pytest.mark.parametrize("fault", FAULTS)
def test_fault_switched_mid_run_takes_effect_at_its_tick_whatever_the_batch(fault):
    """The byte stream, DRDY ticks and edges of a chip computing 512 conversions ahead equal
    those of one computing each when it is due, with the fault switched on and off between."""
    _, got, on, off = session(fault, batch=512)
    _, ref, on1, off1 = session(fault, batch=1)
    assert (on, off) == (on1, off1)
    assert got == ref


@pytest.mark.parametrize("fault", FAULTS)
def test_before_the_switch_and_after_the_clear_the_chip_is_as_if_never_faulty(fault):
    chip, seen, on, off = session(fault, batch=512)
    twin, clean, on0, _ = session(fault, batch=512, switch=False)
    before, during, found, after = seen
    assert before == clean[0] and on == on0
    healthy = [f for f in clean[1]]
    assert all(t is not None and f[:1] == b"\xc0" for t, _, _, f in before)
    if fault in DEAD:
        # a dead DRDY: no edge while it lasts (waits time out), the pin stuck or floating high
        falls = {n for _, n, _, _ in during}
        assert all(t is None for t, _, _, _ in during) and falls == {before[-1][1]}
        assert all(pin is (fault != "drdy-stuck-low") for _, _, pin, _ in during)
        if fault.startswith("absent"):
            byte = 0x00 if fault == "absent-0x00" else 0xFF
            assert all(f == bytes([byte] * 9) for _, _, _, f in during)
        else:
            assert all(f[:1] == b"\xc0" for _, _, _, f in during)   # data still clocks out
        # the re-probe after the clear finds the chip, and conversions come again
        assert found[:2] == (0x53, REGS[1:12]) and chip.violations == []
        assert all(t is not None and f[:1] == b"\xc0" for t, _, _, f in after)
        first = found[2]
        assert first - off <= A.SETTLE_TICKS[DR] + 300      # START's settling, plus the probe's bytes
        assert np.all(np.diff([first] + [t for t, _, _, _ in after]) == D)
        return
    ticks = [t for t, _, _, _ in during]
    if fault == "clock-drift":
        assert all(f[:1] == b"\xc0" for _, _, _, f in during)
        assert np.diff(ticks).mean() < D                        # a fast clock: shorter periods
        assert ticks[-1] < clean[1][-1][0]
        return
    # data faults: DRDY on the schedule, the frames spoiled from the first conversion after the switch
    assert ticks == [t for t, _, _, _ in healthy]
    codes = [A.parse_frame(f) for _, _, _, f in during]
    ref = [A.parse_frame(f) for _, _, _, f in healthy]
    if fault == "status-corrupt":
        assert all(s >> 20 != 0xC for s, _ in codes)
        assert [c for _, c in codes] == [c for _, c in ref]     # only the header
    elif fault == "bit-flips":
        assert sum(a != b for a, b in zip(codes, ref)) > 40     # 72 bits at 5 % each
    elif fault == "clipping":
        assert all(c[0] == A.FULL_SCALE_CODE for _, c in codes) and [c[1] for _, c in codes] == [c[1] for _, c in ref]
    # cleared: the same bytes as the chip that never had the fault (the noise stream untouched)
    assert after == clean[3]


def test_a_frame_converted_before_the_switch_is_read_unchanged():
    """Data faults act on the conversions from the switch on: the frame converted just before
    it reads as it was (bit flips, on the wire, act on every byte read after the switch)."""
    for fault in ("clipping", "status-corrupt"):
        chip, twin = started(512), started(512)
        for c in (chip, twin):
            c.wait_drdy()
        chip.set_fault(fault, 1.0 if fault == "status-corrupt" else None)
        assert cmd(chip, *bytes(9)) == cmd(twin, *bytes(9))
        chip.wait_drdy()
        twin.wait_drdy()
        assert cmd(chip, *bytes(9)) != cmd(twin, *bytes(9))


def test_absent_chip_at_run_time_reads_constant_id_then_answers_again():
    chip = started(512)
    frames(chip, 5)
    for fault, value in (("absent-0x00", 0x00), ("absent-0xff", 0xFF)):
        chip.set_fault(fault)
        cmd(chip, A.SDATAC)
        assert cmd(chip, A.RREG | A.ID, 11, *([0] * 12))[2:] == bytes([value] * 12)
        falls = chip.drdy_falls
        chip.advance(0.1)
        assert chip.drdy_falls == falls and chip.drdy is True
        chip.set_fault(None)
        assert probe(chip) == (0x53, REGS[1:12])
        chip.wait_drdy(0.01)
        assert chip.drdy_falls == falls + 1 and chip.drdy is False


def test_set_fault_refuses_unknown_faults_and_rates():
    chip = ADS1292()
    with pytest.raises(ValueError, match="unknown fault"):
        chip.set_fault("gremlins")
    with pytest.raises(ValueError):
        chip.set_fault("bit-flips", 2.0)
    with pytest.raises(ValueError):
        chip.set_fault("clock-drift", 0.7)
    chip.set_fault("clock-drift")
    assert chip.fault_rate == 0.005 and chip.clock_ratio == pytest.approx(1.005)
    chip.set_fault(None)
    assert chip.clock_ratio == 1.0


def drift_bus(rate, seconds, switch_at=None, noise=False):
    """Chip A nominal, chip B's oscillator at 1 + rate (from the start, or from switch_at s);
    a linear ramp on CH1 of both. Time moves from DRDY to DRDY (no SPI traffic: nothing but
    the clocks moves it). Returns (bus, DRDY ticks of A, of B, CH1 codes of A, of B)."""
    t = np.arange(int((seconds + 0.5) * GRID_HZ)) / GRID_HZ
    ramp = np.c_[0.1 * t, np.zeros(t.size)]
    a = ADS1292(seed=1, noise=noise, batch=512)
    b = ADS1292(seed=2, noise=noise, batch=512,
                fault="clock-drift" if switch_at is None else None, fault_rate=rate if switch_at is None else None)
    bus = SPIBus([a, b])
    for c in (a, b):
        c.load(ramp, GRID_HZ)
    bus.advance(0.05)
    for i in (0, 1):
        bus.select(i)
        bus.transfer([A.SDATAC, A.WREG | A.CONFIG1, 10, *REGS[1:12], A.RDATAC])
        bus.select(None)
    bus.start = True
    ticks, codes = ([], []), ([], [])
    end = int((0.05 + seconds) * A.F_MOD)
    switched = switch_at is None
    while True:
        nxt = min(c.schedule.next_drdy for c in (a, b))
        if nxt > end:
            break
        if not switched and nxt > int((0.05 + switch_at) * A.F_MOD):
            b.set_fault("clock-drift", rate)
            switched = True
            continue
        for i, c in enumerate((a, b)):
            n = c.conversions
            c.advance_to_tick(nxt)
            if c.conversions != n:
                ticks[i].append(c.tick)
                codes[i].append(A.parse_frame(c.frame)[1][0])
    return bus, [np.array(x) for x in ticks], [np.array(x) for x in codes]


@pytest.mark.parametrize("rate", [0.005, -0.005])
def test_clock_drift_slips_the_conversions_by_the_rate(rate):
    bus, (ta, tb), (ca, cb) = drift_bus(rate, seconds=4.0)
    a, b = bus.chips
    start = a.start_tick
    assert b.start_tick == start
    # chip A on the nominal schedule; chip B's k-th DRDY at the first tick at or after
    # (settling + k D) own ticks, own ticks running at 1 + rate
    assert np.array_equal(ta, start + A.SETTLE_TICKS[DR] + D * np.arange(len(ta)))
    own = A.SETTLE_TICKS[DR] + D * np.arange(len(tb))
    assert np.array_equal(tb, start + np.ceil(own / (1 + rate) - 1e-9).astype(int))
    assert np.all(np.diff(tb) >= np.floor(D / (1 + rate))) and np.all(np.diff(tb) <= np.ceil(D / (1 + rate)))
    # the slip: B converts (1 + rate) x as often as A; over 4 s at +-0.5 %, +-20 conversions (20 ms)
    assert len(tb) - len(ta) == pytest.approx(len(ta) * rate, abs=1.5)
    common = min(len(ta), len(tb))
    slip = (tb[:common] - ta[:common]) / A.F_MOD
    k = np.arange(common)
    expected = (A.SETTLE_TICKS[DR] + D * k) / A.F_MOD * (1 / (1 + rate) - 1)
    assert np.all(np.abs(slip - expected) <= 1 / A.F_MOD)        # within the whole-tick rounding
    assert abs(slip[-1]) > 0.019
    # the data follow the chip's own DRDY times: on a ramp the codes slip with them
    ref = convert(b.analog.volts, None, b.config, ticks=tb, rng=NO_NOISE, step=b.analog.step, grid_tick0=b.analog.grid_tick0)
    assert np.array_equal(cb, ref[:, 0])
    codes_per_tick = 0.1 / A.F_MOD * A.FULL_SCALE_CODE / A.VREF_LOW
    assert np.all(np.abs((cb[:common] - ca[:common]) - slip * A.F_MOD * codes_per_tick) <= 2.0)


def test_clock_drift_switched_on_and_off_mid_run():
    """Switched on at 1 s: the pending DRDY keeps its tick, the ones after follow the new
    clock; cleared, the period is nominal again and the phase slipped stays slipped."""
    rate = 0.005
    bus, (ta, tb), _ = drift_bus(rate, seconds=2.3, switch_at=1.0)
    a, b = bus.chips
    pending = ta[ta > int((0.05 + 1.0) * A.F_MOD)][0]
    before, after = tb[tb <= pending], tb[tb > pending]
    assert np.array_equal(before, ta[:len(before)])
    k = np.arange(1, len(after) + 1)
    assert np.array_equal(after, pending + np.ceil(k * D / (1 + rate) - 1e-9).astype(int))
    b.set_fault(None)
    t0 = b.schedule.next_drdy
    ticks = []
    for _ in range(50):
        bus.wait_drdy(1)
        ticks.append(b.tick)
    assert ticks[0] == t0 and np.all(np.diff(ticks) == D)
    assert (t0 - ta[0]) % D != 0                                 # slipped against chip A for good


def test_world_idle_returns_within_a_millisecond_without_drdy(tmp_path):
    """DRDY dies at run time under the firmware (in-process): the World's idle still returns
    every <= 1 ms of simulated time (a core's systick), so the main loop keeps running and
    answers; the DRDY edges come again once the fault is cleared."""
    from desktop.devicesim.runners import start_device
    from desktop.devicesim.world import SYSTICK_S, make_world
    w = make_world(serial=None, motion="stationary", seconds=3.0, seed=3, rate=1000)
    dev = start_device(w, str(tmp_path), kind="cpython")
    dev.run_until(0.5)
    for fault in ("drdy-stuck-high", "absent-0x00", "drdy-stuck-low"):
        w.handheld.set_fault(0, fault)
        steps = []
        idle = w.idle

        def timed(*args, **kw):
            t = w.time
            idle(*args, **kw)
            steps.append(w.time - t)
        w.idle = timed
        edges, t0, lines = w.drdy_edges, w.time, len(w.lines())
        w.send(b"version\n")
        dev.run_until(t0 + 0.2)
        w.idle = idle
        assert w.drdy_edges == edges                       # no DRDY edge reached the firmware
        # whole ticks: a wait ends on the first tick boundary at or after 1 ms
        assert len(steps) >= 50 and max(steps) <= SYSTICK_S + 1.0 / A.F_MOD
        replies = [json.loads(x) for x in w.lines()[lines:] if x.startswith("{")]
        assert any(r.get("cmd") == "version" and r.get("ok") for r in replies)   # the loop ran
        w.handheld.set_fault(0, None)
        dev.run_until(w.time + 0.2)
    dev.close()
