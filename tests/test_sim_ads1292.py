"""The ADS1292 emulator against the datasheet facts (../shared/reference/ads1292-and-runtimes.md)."""

import numpy as np
import pytest

from desktop.sim.ads1292 import registers as A
from desktop.sim.ads1292.bus import SPIBus
from desktop.sim.ads1292.chip import ADS1292
from desktop.sim.ads1292.convert import convert

LSB = A.VREF_LOW / A.FULL_SCALE_CODE          # 288.5 nV at gain 1 [DS §8.3.8]


def booted(chip=None, **kw):
    chip = chip or ADS1292(**kw)
    chip.advance(0.05)                        # past tPOR = 32 ms
    chip.select(True)
    chip.transfer([A.SDATAC])
    return chip


def rreg(chip, addr, count):
    return chip.transfer([A.RREG | addr, count - 1] + [0] * count)[2:]


def wreg(chip, addr, values):
    chip.transfer([A.WREG | addr, len(values) - 1] + list(values))


def test_reset_values_and_id():
    chip = booted(seed=0)
    assert list(rreg(chip, 0, 12)) == [0x53, 0x02, 0x80, 0x10, 0, 0, 0, 0, 0, 0, 0x02, 0x0C]
    assert chip.violations == []
    assert rreg(booted(chip_id=0x73), 0, 1) == b"\x73"


@pytest.mark.parametrize("fault, value", [("absent-0x00", 0x00), ("absent-0xff", 0xFF)])
def test_absent_chip_reads_constant_id_and_never_drdy(fault, value):
    chip = booted(fault=fault)
    assert rreg(chip, 0, 1) == bytes([value])
    chip.start = True
    with pytest.raises(TimeoutError):
        chip.wait_drdy(timeout=0.1)
    assert chip.drdy is True


def test_fixed_bits_hold_and_id_is_read_only():
    chip = booted()
    wreg(chip, A.CONFIG1, [0x7D])             # bits 6:3 must be 0
    wreg(chip, A.CONFIG2, [0x00])             # bit 7 must be 1
    wreg(chip, A.LOFF, [0x02])                # bit 4 = 1, bit 1 = 0
    wreg(chip, A.RESP1, [0x00])               # bit 1 must be 1
    wreg(chip, A.ID, [0x12])
    assert list(rreg(chip, 0, 4)) == [0x53, 0x05, 0x80, 0x10]
    assert rreg(chip, A.RESP1, 1) == b"\x02"
    assert len(chip.violations) == 5
    wreg(chip, A.CH1SET, [0x14])               # all bits writable
    assert rreg(chip, A.CH1SET, 1) == b"\x14"


def test_timing_rules_are_enforced():
    chip = ADS1292()
    chip.select(True)
    chip.transfer([A.SDATAC])                 # before tPOR: ignored
    assert chip.rdatac and chip.violations
    chip.advance(0.05)
    chip.transfer([A.SDATAC])
    assert not chip.rdatac
    chip.transfer([A.RDATAC, A.RREG, 0, 0])   # RREG ignored in RDATAC
    assert any("RREG ignored" in v for v in chip.violations)
    chip.transfer([A.SDATAC, A.STANDBY, A.RDATAC])
    assert not chip.rdatac                    # only WAKEUP may follow STANDBY
    chip.transfer([A.WAKEUP, A.RDATAC])
    assert chip.rdatac


def dc_chip(volts, regs=None, **kw):
    """A booted chip with constant inputs (V), configured, converting in RDATAC."""
    chip = booted(**kw)
    chip.load(np.tile(volts, (8, 1)), 16000)
    wreg(chip, 1, (regs or A.standard_registers(dr=2))[1:12])
    chip.transfer([A.RDATAC])
    chip.select(False)
    chip.start = True
    return chip


def read_frame(chip):
    chip.wait_drdy()
    chip.select(True)
    frame = chip.transfer(bytes(9))
    chip.select(False)
    return frame


@pytest.mark.parametrize("v, code", [(1000 * LSB, 1000), (-LSB, -1), (0.0, 0),
                                     (A.VREF_LOW, 0x7FFFFF), (5.0, 0x7FFFFF),
                                     (-A.VREF_LOW * 2 ** 23 / (2 ** 23 - 1), -0x800000), (-5.0, -0x800000)])
def test_twos_complement_and_clipping(v, code):
    chip = dc_chip([v, -v], noise=False)
    for _ in range(4):                        # sinc3 settled by the 4th DRDY [DS §8.5.1.12]
        frame = read_frame(chip)
    status, codes = A.parse_frame(frame)
    assert status == 0xC00000                 # 1100 + LOFF_STAT 0 + GPIO 00 [DS §8.5.1.5]
    assert codes[0] == code
    assert frame[3:6] == (code & 0xFFFFFF).to_bytes(3, "big")
    assert codes[1] == max(min(round(-v / LSB), 0x7FFFFF), -0x800000)


def test_gain_and_4v_reference_scale_codes():
    regs = A.standard_registers(dr=2, gain=6, vref_4v=True)
    chip = dc_chip([0.1, -0.2], regs, noise=False)
    for _ in range(4):
        _, codes = A.parse_frame(read_frame(chip))
    full = A.FULL_SCALE_CODE / A.VREF_HIGH * 6
    assert codes == [round(0.1 * full), round(-0.2 * full)]


def test_data_rate_and_settling_time():
    for dr, rate in enumerate(A.DATA_RATES):
        chip = dc_chip([0.0, 0.0], A.standard_registers(dr=dr))
        t0 = chip.tick
        chip.wait_drdy()
        assert chip.tick - t0 == A.SETTLE_TICKS[dr]
        chip.wait_drdy()
        assert chip.tick - t0 - A.SETTLE_TICKS[dr] == A.F_MOD // rate


def test_temperature_sensor_mux():
    regs = A.standard_registers(dr=1, mux=(A.MUX_TEMP, A.MUX_SHORT))
    chip = dc_chip([0.5, 0.5], regs, seed=1)
    chip.temperature_c = 37.0
    codes = np.array([A.parse_frame(read_frame(chip))[1] for _ in range(200)])
    temp = A.volts_to_temperature(A.codes_to_volts(codes[:, 0], 1))
    # ADC noise 0.7 uV x 3.3 at 250 SPS, gain 1 -> 4.7 mC per sample; mean of 200
    assert abs(temp.mean() - 37.0) < 5 * 4.7e-3
    assert abs(codes[:, 1].mean()) < 5 * 2.3e-6 / LSB / np.sqrt(200) + 1   # shorted input


def test_sinc3_step_response_settles_on_fourth_conversion():
    chip = booted(noise=False)
    wreg(chip, 1, A.standard_registers(dr=3)[1:12])
    chip.transfer([A.RDATAC])
    chip.select(False)
    t = np.arange(16000) / 16000
    volts = np.where(t[:, None] >= 0.1, 1.0, 0.0) * np.ones((1, 2))
    chip.load(volts, 16000, t0=0.0)
    chip.start = True
    codes = []
    while chip.time < 0.11:
        codes.append(A.parse_frame(read_frame(chip))[1][0])
    full = round(1.0 / LSB)
    after = [c for c in codes if c > 0]
    # a sinc3 spans three conversion periods: at most 3 partial results, rising
    assert after[3:] == [full] * len(after[3:]) and len(after) > 4
    assert after[:3] == sorted(after[:3]) and after[0] < full


def test_byte_path_equals_vectorised_path_with_noise():
    rng = np.random.default_rng(5)
    volts = np.cumsum(rng.standard_normal((16000, 2)), axis=0) * 1e-3   # 1 s of a random walk
    chip = booted(seed=42)
    wreg(chip, 1, A.standard_registers(dr=4, gain=2)[1:12])
    chip.transfer([A.RDATAC])
    chip.select(False)
    chip.load(volts, 16000)
    chip.start = True
    got = [A.parse_frame(read_frame(chip))[1] for _ in range(1500)]
    ref = convert(volts, None, chip.config, first_tick=chip.start_tick + A.SETTLE_TICKS[4],
                    n=1500, rng=np.random.default_rng(42))
    assert np.array_equal(np.array(got), ref)


def test_drdy_rises_on_any_sclk_of_the_shared_bus():
    a, b = ADS1292(), ADS1292()
    bus = SPIBus([a, b])
    bus.advance(0.05)
    bus.start = True
    a.wait_drdy()
    assert a.drdy is False
    bus.select(1)
    bus.transfer([0x00])                      # talking to chip B
    assert a.drdy is True                     # chip A saw SCLK [DS §8.5.1.6]
    assert a.drdy_falls == 1


def test_faults_status_corrupt_and_bit_flips():
    chip = dc_chip([0.1, 0.1], fault="status-corrupt", fault_rate=1.0)
    assert A.parse_frame(read_frame(chip))[0] >> 20 != 0xC
    chip = dc_chip([0.1, 0.1], fault="bit-flips", fault_rate=0.5, noise=False)
    frames = [read_frame(chip) for _ in range(5)]
    assert any(A.parse_frame(f)[0] >> 20 != 0xC for f in frames)
    chip = dc_chip([0.1, 0.1], fault="clipping")
    assert A.parse_frame(read_frame(chip))[1][0] == 0x7FFFFF
    chip = dc_chip([0.1, 0.1], fault="drdy-stuck-low")
    assert chip.drdy is False
    with pytest.raises(TimeoutError):
        chip.wait_drdy(0.01)


@pytest.mark.parametrize("batch, temp_c", [(1, 25.0), (512, 25.0), (64, 5.0)])
def test_two_chips_on_one_bus_follow_the_shared_clock(batch, temp_c):
    """... and each chip's reference drift away from 25 C (tests/test_sim_temperature.py)."""
    from desktop.sim.handheld import Handheld
    from desktop.sim.scenario import Scenario
    sc = Scenario(seconds=0.3, rate=1000, motion="hand", temp_c=temp_c)
    hw = Handheld(sc, t0=0.0, batch=batch)
    assert [c.batch for c in hw.chips] == [batch, batch]
    assert [c.vref_tempco for c in hw.chips] == list(sc.vref_tempco())
    bus = hw.bus
    bus.advance(0.05)
    for i, regs in enumerate(sc.registers()):
        bus.select(i)
        bus.transfer([A.SDATAC, A.WREG | 1, 10] + regs[1:12] + [A.RDATAC])
        bus.select(None)
    bus.start = True
    rows = []
    for _ in range(100):
        bus.wait_drdy(0)
        row = []
        for i in (0, 1):
            bus.select(i)
            row += A.parse_frame(bus.transfer(bytes(9)))[1]
        bus.select(None)
        rows.append(row)
    assert hw.chips[0].tick == hw.chips[1].tick
    _, _, adc_a, adc_b = sc.rngs()
    ref = [convert(c.analog.volts, hw.grid["temp"], A.Config(c.registers), n=100, rng=rng, step=c.analog.step,
                     first_tick=c.start_tick + A.SETTLE_TICKS[3], grid_tick0=c.analog.grid_tick0,
                     vref_tempco=c.vref_tempco)
           for c, rng in zip(hw.chips, (adc_a, adc_b))]
    assert np.array_equal(np.array(rows), np.concatenate(ref, axis=1))
    temp = A.volts_to_temperature(A.codes_to_volts(np.array(rows)[:, 3], 1))
    k_b = sc.vref_tempco()[1]    # chip B reads its sensor against its own reference
    assert abs(temp.mean() - A.volts_to_temperature(A.temperature_volts(temp_c) / (1 + k_b * (temp_c - 25.0)))) < 0.05


def scripted_session(chip):
    """Drive a chip through a session that touches everything a batch cache
    depends on; return what the host saw: every byte read, DRDY ticks, violations."""
    rng = np.random.default_rng(7)
    t = np.arange(int(0.6 * 16000)) / 16000
    volts = np.c_[0.01 * np.sin(2 * np.pi * 13 * t), 1e-3 * rng.standard_normal(t.size)]
    seen = []

    def frames(k):
        for _ in range(k):
            chip.wait_drdy()
            seen.append(chip.tick)
            chip.select(True)
            seen.append(chip.transfer(bytes(9)))
            chip.select(False)

    def command(*data):
        chip.select(True)
        chip.transfer([A.SDATAC, *data, A.RDATAC])
        chip.select(False)

    booted(chip)
    chip.load(volts[:3200], 16000)                     # the first 0.2 s; the rest comes later
    wreg(chip, 1, A.standard_registers(dr=4, gain=2, mux=(A.MUX_NORMAL, A.MUX_TEMP))[1:12])
    chip.transfer([A.RDATAC])
    chip.select(False)
    chip.start = True
    frames(150)
    command(A.WREG | A.CONFIG1, 0, 3)                 # data rate 2000 -> 1000 SPS mid-stream
    frames(60)
    chip.load(volts * 1.5, 16000)                     # new analog input, same time base
    frames(40)
    command(A.WREG | A.CH1SET, 0, 0x40)               # gain 4: the schedule runs on
    frames(30)
    chip.temperature_c = 40.0                         # read by CH2 (MUX=0100)
    frames(30)
    chip.advance(0.0123)                              # unread conversions are replaced
    frames(20)
    command(A.STOP)
    chip.start = False
    command(A.WREG | A.CONFIG1, 0, 0x80 | 4)          # single shot
    for _ in range(5):
        command(A.START)
        frames(1)
    seen.append(chip.conversions)
    seen.append(chip.drdy_falls)
    seen.append(list(chip.violations))
    return seen


@pytest.mark.parametrize("fault", [None, "status-corrupt", "bit-flips", "clipping"])
@pytest.mark.parametrize("batch", [7, 512])
def test_batched_chip_gives_the_unbatched_byte_stream(fault, batch):
    rate = 0.2 if fault == "status-corrupt" else 0.01 if fault == "bit-flips" else None
    ref = scripted_session(ADS1292(seed=3, fault=fault, fault_rate=rate))
    got = scripted_session(ADS1292(seed=3, fault=fault, fault_rate=rate, batch=batch))
    assert len(got) == len(ref) > 600
    assert got == ref


def test_batch_can_change_mid_stream_and_rng_can_be_replaced():
    chips = [dc_chip([1e-3, -1e-3], seed=11, batch=b) for b in (1, 64)]
    out = [[], []]
    for step in range(6):
        for chip, rows in zip(chips, out):
            if step == 2:
                chip.batch = 3 if chip.batch > 1 else 1
            if step == 4:
                chip.rng = np.random.default_rng(99)
            for _ in range(20):
                rows.append(read_frame(chip))
    assert out[0] == out[1]
    with pytest.raises(ValueError):
        chips[0].batch = 0


def test_wait_drdy_timeout_below_one_tick_still_moves_time():
    chip = dc_chip([0.0, 0.0])
    chip.wait_drdy()
    tick = chip.tick
    with pytest.raises(TimeoutError):
        chip.wait_drdy(timeout=0.3 / A.F_MOD)          # next DRDY is a whole period away
    assert chip.tick == tick + 1                       # rounded up to the next tick boundary
    with pytest.raises(TimeoutError):
        chip.wait_drdy(timeout=0.0)                    # a poll: no time passes
    assert chip.tick == tick + 1
    with pytest.raises(ValueError):
        chip.wait_drdy(timeout=-1e-6)
    period = chip.config.decimation
    chip.advance_to_tick(tick + period - 1)
    assert chip.wait_drdy(timeout=0.5 / A.F_MOD) == 1 / A.F_MOD   # due within the rounded timeout
    assert chip.tick == tick + period
    for _ in range(3 * period):                       # retrying on a sub-tick timeout progresses
        try:
            chip.wait_drdy(timeout=1e-9)
        except TimeoutError:
            pass
    assert chip.tick == tick + 4 * period


def test_bus_wait_drdy_timeout_keeps_the_chips_in_step():
    a, b = ADS1292(fault="drdy-stuck-high"), ADS1292()
    bus = SPIBus([a, b])
    bus.advance(0.05)
    bus.start = True
    for _ in range(3):
        with pytest.raises(TimeoutError):
            bus.wait_drdy(0, timeout=1e-7)
    assert a.tick == b.tick == int(0.05 * A.F_MOD) + 3
