"""Firmware parts against the byte-level ADS1292 emulator, in-process (CPython).

Driver: power-up, ID probe, register read-back, RDATAC frames decoded to the
codes the emulator produced; ring overflow and corrupted frames counted, never
silently mixed into samples. Storage: atomic save, recovery from either file,
a corrupt calibration leaves the device uncalibrated with a reason.
"""

import os
import sys

import numpy as np
import pytest

from desktop.devicesim.runner import DEVICE, make_world, start_device
from desktop.devicesim.physics import NT_PER_CODE

sys.path.insert(0, DEVICE)
import ads1292  # noqa: E402  (device/ is a flat MicroPython module folder)
import store  # noqa: E402


def boot(tmp_path, **kw):
    w = make_world(seed=3, serial=None, **kw)
    w.analog.motion.still(30)
    dev = start_device(w, str(tmp_path), kind="cpython")
    dev.run_until(0.3)
    return w, dev


def test_boot_configures_both_chips_without_violations(tmp_path):
    w, dev = boot(tmp_path)
    adc = dev.app.adc
    assert adc.ids == [0x53, 0x53]
    for chip in w.chips:
        assert chip.violations == []          # datasheet timing and fixed bits respected
    r0, r1 = w.chips[0].registers, w.chips[1].registers
    assert r0[1] == 0x04 and r1[1] == 0x04    # CONFIG1: DR=100, 2000 SPS
    assert r0[2] == 0xA0                      # CONFIG2: internal reference buffer on, 2.42 V
    assert r1[5] == 0x14                      # CH2SET chip 1: gain 1, MUX=0100 temperature
    assert dev.app.fault is None
    dev.close()


def test_frames_decode_to_the_field(tmp_path):
    """Stationary sensor: decimated codes x nT/code equal the sensor's output within noise."""
    w, dev = boot(tmp_path)
    got = []
    app = dev.app
    orig = app._on_sample

    def spy(sx, sy, sz, st):
        got.append((sx, sy, sz, st))
        orig(sx, sy, sz, st)
    app._sample_cb = spy
    dev.run_until(1.3)
    win = app.cfg["window"]
    codes = np.array(got[-100:], float) / win
    truth = w.analog.sensor.measure(w.analog.motion.field_body(np.array([1.0]), w.analog.field_world))[0]
    mean_nt = codes[:, :3].mean(axis=0) * NT_PER_CODE
    # ADC noise at 2000 SPS, gain 1: 7.3 uV rms = 0.33 nT per frame; 500 frames averaged -> 0.015 nT,
    # plus code rounding; allow 0.1 nT
    assert np.allclose(mean_nt, truth, atol=0.1)
    assert abs(app.temp_c - 25.0) < 0.1
    st = app.adc.state
    assert st[ads1292.OVERFLOW] == 0 and st[ads1292.BADSYNC] == 0 and app.dec.gaps == 0
    dev.close()


def test_ring_overflow_is_counted_and_blocks_discarded(tmp_path):
    w, dev = boot(tmp_path)
    adc, board = dev.app.adc, dev.board
    dev.run_until(0.5)
    dev.app.step()                            # the ring is empty
    n_before = dev.app.dec.samples
    w.until = 10.0
    # the main loop stalls: only the ISR runs; each decim DRDY edges complete one block
    for _ in range((adc.ring_frames + 37) * adc.decim):
        board.idle()
    assert adc.state[ads1292.OVERFLOW] == 37 + 1   # the ring holds ring_frames - 1
    # draining 127 samples costs 127 x 1.12 ms of charged main-loop time (runner.COSTS_S)
    dev.run_until(w.time + 0.5)
    assert dev.app.dec.gaps == 1 and dev.app.dec.discarded == 0
    assert dev.app.dec.samples > n_before
    dev.close()


def test_corrupt_status_words_are_dropped(tmp_path):
    w, dev = boot(tmp_path, faults=("status-corrupt", None))
    dev.run_until(3.0)
    st = dev.app.adc.state
    adc = dev.app.adc
    # only the window frames of each block are read (ads1292.py)
    reads, bad = st[ads1292.FRAMES] * adc.window // adc.decim, st[ads1292.BADSYNC]
    # 1 % of frames read corrupted (emulator default fault_rate): binomial, 5 sigma
    assert abs(bad - 0.01 * reads) < 5 * np.sqrt(0.01 * reads)
    assert 0 < dev.app.dec.discarded <= bad   # a block with a bad frame is discarded
    assert 0 < dev.app.dec.gaps <= bad        # and its block number is missing: one gap
    dev.close()


@pytest.mark.parametrize("fault, read", [("absent-0x00", 0x00), ("absent-0xff", 0xFF)])
def test_absent_chip_is_a_clear_fault(tmp_path, fault, read):
    w, dev = boot(tmp_path, faults=(None, fault))
    app = dev.app
    assert app.fault.startswith("ADS1292 #1: ID register read 0x%02X, expected 0x53" % read)
    assert "check CS1" in app.fault
    w.send(b"status\nstart-cal\n")
    dev.run_until(0.5)
    lines = w.lines()
    assert '"state": "fault"' in lines[-2] and '"error": "fault"' in lines[-1]
    dev.close()


def test_bad_rate_and_gain_name_the_value():
    with pytest.raises(ValueError, match="3000"):
        ads1292.rate_code(3000)
    with pytest.raises(ValueError, match="gain 5"):
        ads1292.gain_code(5)


def test_isr_sign_extension():
    assert ads1292.to_signed24(0x7F, 0xFF, 0xFF) == 2 ** 23 - 1
    assert ads1292.to_signed24(0x80, 0x00, 0x00) == -2 ** 23
    assert ads1292.to_signed24(0xFF, 0xFF, 0xFF) == -1


def test_store_atomic_and_recovery(tmp_path):
    root = str(tmp_path)
    store.save(root, "cal", {"a": 1})
    store.save(root, "cal", {"a": 2})
    assert store.load(root, "cal") == ({"a": 2}, "json", None)
    # torn write of the primary: the backup (previous record) is used and the problem named
    with open(tmp_path / "cal.json", "r+") as f:
        f.seek(5)
        f.write("X")
    body, src, problem = store.load(root, "cal")
    assert body == {"a": 1} and src == "bak" and "checksum mismatch" in problem
    # power lost between the renames: only cal.tmp (complete) and cal.bak exist
    store.save(root, "cal", {"a": 3})
    os.rename(tmp_path / "cal.json", tmp_path / "cal.tmp")
    body, src, _ = store.load(root, "cal")
    assert body == {"a": 3} and src == "tmp" and os.path.exists(tmp_path / "cal.json")
    # a truncated tmp beside a good primary is ignored
    with open(tmp_path / "cal.tmp", "w") as f:
        f.write('{"a": 4')
    assert store.load(root, "cal")[0] == {"a": 3}
    store.remove(root, "cal")
    assert store.load(root, "cal") == (None, None, "no cal file")


@pytest.mark.parametrize("content", [b"", b"\x00\xff" * 100, b'{"matrix": 1}\n#crc32=00000000\n', b"x" * 20000])
def test_corrupt_calibration_boots_uncalibrated(tmp_path, content):
    flash = tmp_path / "flash"
    flash.mkdir()
    (flash / "cal.json").write_bytes(content)
    w, dev = boot(tmp_path)
    app = dev.app
    assert app.cal is None and app.cal_problem and app.fault is None
    w.send(b"status\n")
    dev.run_until(0.6)
    assert '"calibrated": false' in w.lines()[-1] and '"cal_problem": "cal.json:' in w.lines()[-1]
    dev.close()
