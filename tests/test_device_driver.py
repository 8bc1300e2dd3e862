"""Firmware parts against the byte-level ADS1292 emulator, in-process (CPython).

Driver: power-up, ID probe, register read-back, RDATAC frames decoded to the
codes the emulator produced; ring overflow and corrupted frames counted, never
silently mixed into samples. Storage: atomic save, recovery from either file,
a corrupt calibration leaves the device uncalibrated with a reason.
"""

import os

import numpy as np
import pytest

from desktop.devicesim.runners import start_device
from desktop.devicesim.world import make_world
from desktop.firmware.files import import_device
from desktop.sim.ads1292.convert import noise_gain_factor
from desktop.sim.ads1292.registers import FULL_SCALE_CODE, NOISE_UV_GAIN6, VREF_LOW

acquisition = import_device("acquisition")
ads1292 = import_device("ads1292")
store = import_device("store")


RATE = import_device("config").SCHEMA["rate"][0]    # the firmware's default data rate


def boot(tmp_path, fault=(None, None), seconds=5.0):
    """The firmware on its default config.json (none) in a still handheld."""
    w = make_world(serial=None, motion="stationary", seconds=seconds, seed=3, rate=RATE, fault=fault)
    dev = start_device(w, str(tmp_path), kind="cpython")
    dev.run_until(0.3)
    return w, dev


def test_boot_configures_both_chips_without_violations(tmp_path):
    w, dev = boot(tmp_path)
    adc = dev.app.supervisor.adc
    assert adc.ids == [0x53, 0x53]
    for chip in w.chips:
        assert chip.violations == []          # datasheet timing and fixed bits respected
    r0, r1 = w.chips[0].registers, w.chips[1].registers
    dr = ads1292.rate_code(RATE)             # CONFIG1: continuous conversion, DR (1000 SPS: 011)
    assert RATE == 1000 and r0[1] == dr == 0x03 and r1[1] == dr
    assert r0[2] == 0xA0                      # CONFIG2: internal reference buffer on, 2.42 V
    assert r1[5] == 0x14                      # CH2SET chip 1: gain 1, MUX=0100 temperature
    assert dev.app.supervisor.fault is None
    dev.close()


def test_frames_decode_to_the_field(tmp_path):
    """Stationary sensor: decimated codes x nT/code equal the sensor's output within noise."""
    w, dev = boot(tmp_path)
    got = []
    app = dev.app
    orig = app.output.sample

    def spy(sx, sy, sz, st):
        got.append((sx, sy, sz, st))
        orig(sx, sy, sz, st)
    app._sample_cb = spy
    dev.run_until(1.3)
    win = app.cfg["window"]
    codes = np.array(got[-100:], float) / win
    lsb = w.scenario.nt_per_code()
    a, c = w.handheld.sensor.raw_model()                 # raw nT = A b + c, nominal scale
    _, b = w.handheld.truth(np.array([1.0]))
    truth = b[0] @ a.T + c
    mean_nt = codes[:, :3].mean(axis=0) * lsb
    # per frame: the ADS1292's noise at the data rate, gain 1 [DS §7.1] in nT, and the sensor's;
    # averaged over the 100 x window frames read; 5 sigma, plus half a code of rounding
    adc_nt = NOISE_UV_GAIN6[ads1292.rate_code(RATE)] * 1e-6 * noise_gain_factor(1) / (VREF_LOW / FULL_SCALE_CODE) * lsb[0]
    sigma = np.hypot(adc_nt, w.scenario.noise) / np.sqrt(100 * win)
    assert np.all(np.abs(mean_nt - truth) < 5 * sigma + 0.5 * lsb), (mean_nt - truth, sigma)
    # the die sensor: 490 uV/C [DS Eq.3] against the same ADC noise, averaged over a block
    assert abs(app.output.temp_c - w.scenario.temp_c) < 5 * (adc_nt / lsb[0] * VREF_LOW / FULL_SCALE_CODE) / 490e-6
    st = app.acq.state
    assert st[acquisition.OVERFLOW] == 0 and st[acquisition.BADSYNC] == 0 and app.acq.gaps == 0
    dev.close()


def test_ring_overflow_is_counted_and_blocks_discarded(tmp_path):
    w, dev = boot(tmp_path)
    acq, board = dev.app.acq, dev.board
    dev.run_until(0.5)
    dev.app.step()                            # the ring is empty
    n_before = acq.samples
    w.until = 10.0
    # the main loop stalls: only the ISR runs; each decim DRDY edges complete one block
    for _ in range((acq.ring_frames + 37) * acq.decim):
        board.idle()
    assert acq.state[acquisition.OVERFLOW] == 37 + 1   # the ring holds ring_frames - 1
    # draining 127 samples costs 127 x 1.12 ms of charged main-loop time (runner.COSTS_S)
    dev.run_until(w.time + 0.5)
    assert acq.gaps == 1 and acq.discarded == 0
    assert acq.samples > n_before
    dev.close()


def test_the_service_inside_a_long_step_drains_the_whole_ring(tmp_path):
    """App._service (the finish's steps call it, docs/firmware.md "The finish") empties the ring,
    not one pass's share: a finish's next step follows at once and would overflow what is left."""
    w, dev = boot(tmp_path)
    acq, board = dev.app.acq, dev.board
    dev.run_until(0.5)
    dev.app.step()                            # the ring is empty
    w.until = 10.0
    held = 100                                # the main loop in a long step: only the ISR runs
    for _ in range(held * acq.decim):
        board.idle()
    n_before = acq.samples
    assert held > dev.app._drain
    dev.app._service()
    assert acq.samples - n_before == held and acq.state[acquisition.OVERFLOW] == 0
    dev.close()


def test_corrupt_status_words_are_dropped(tmp_path):
    w, dev = boot(tmp_path, fault=("status-corrupt", None))
    dev.run_until(3.0)
    acq = dev.app.acq
    st = acq.state
    # only the window frames of each block are read (acquisition.py)
    reads, bad = st[acquisition.FRAMES] * acq.window // acq.decim, st[acquisition.BADSYNC]
    # 1 % of frames read corrupted (emulator default fault_rate): binomial, 5 sigma
    assert abs(bad - 0.01 * reads) < 5 * np.sqrt(0.01 * reads)
    assert 0 < acq.discarded <= bad   # a block with a bad frame is discarded
    assert 0 < acq.gaps <= bad        # and its block number is missing: one gap
    dev.close()


@pytest.mark.parametrize("fault, read", [("absent-0x00", 0x00), ("absent-0xff", 0xFF)])
def test_absent_chip_is_a_clear_fault(tmp_path, fault, read):
    w, dev = boot(tmp_path, fault=(None, fault))
    app = dev.app
    assert app.supervisor.fault.startswith("ADS1292 #1: ID register read 0x%02X, expected 0x53" % read)
    assert "check CS1" in app.supervisor.fault
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


class _FrameBoard:
    """Serves fixed 9-byte frames to the DRDY handler: chip 0 X, Y; chip 1 Z, temperature."""

    def __init__(self, codes):
        self.frames = []
        for pair in (codes[:2], codes[2:]):
            f = bytearray(b"\xc0\x00\x00")
            for c in pair:
                f += (c & 0xFFFFFF).to_bytes(3, "big")
            self.frames.append(f)

    def spi_readinto(self, chip, buf):
        buf[:] = self.frames[chip]


@pytest.mark.parametrize("code", [2 ** 23 - 1, -2 ** 23, -1, 0, 1, 0x123456, -0x123456])
def test_isr_sign_extends_24_bit_codes(code):
    """The handler's inline sign extension, through the handler: a boxcar of 3 equal
    frames sums to 3 x the code on every channel."""
    acq = acquisition.Acquisition(_FrameBoard((code, -code if code > -2 ** 23 else 0, code, 7)), 3, 3)
    for _ in range(3):
        acq.isr()
    got = []
    acq.poll(lambda x, y, z, t: got.append((x, y, z, t)))
    assert got == [(3 * code, 3 * (-code if code > -2 ** 23 else 0), 3 * code, 21)]


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
    assert store.load(root, "cal") == (None, None, None)      # no record is no problem


@pytest.mark.parametrize("content", [b"", b"\x00\xff" * 100, b'{"matrix": 1}\n#crc32=00000000\n', b"x" * 20000])
def test_corrupt_calibration_boots_uncalibrated(tmp_path, content):
    flash = tmp_path / "flash"
    flash.mkdir()
    (flash / "cal.json").write_bytes(content)
    w, dev = boot(tmp_path)
    app = dev.app
    assert app.flow.cal is None and app.flow.cal_problem and app.supervisor.fault is None
    w.send(b"status\n")
    dev.run_until(0.6)
    assert '"calibrated": false' in w.lines()[-1] and '"cal_problem": "cal.json:' in w.lines()[-1]
    dev.close()


def test_default_scale_is_the_reference_front_end_the_simulator_models():
    """config.py's scale_x/y/z default (a literal on the device) equals the simulator's
    nominal nT per code (computed from the datasheet LSB and the front end) to its 10 places."""
    from desktop.sim.scenario import Scenario
    schema = import_device("config").SCHEMA
    k = Scenario().nt_per_code()
    for i, axis in enumerate("xyz"):
        assert schema["scale_" + axis][0] == round(k[i], 10)


def test_no_drdy_handler_while_the_registers_are_talked_to(tmp_path):
    """A conversion that ends after START fell must not have its frame read inside a register
    transaction (the handler's chip select would rise under it: a read-back of 0x00 on the
    emulated Pico): stop() and begin() detach the handler, health.py attaches it once started."""
    w, dev = boot(tmp_path)
    board = dev.app.board
    attached = []
    for name in ("spi_write", "spi_write_readinto"):
        orig = getattr(board, name)

        def spy(*a, _orig=orig):
            attached.append(board._handler is not None)
            return _orig(*a)
        setattr(board, name, spy)
    new = dict(dev.app.cfg)
    new["rate"] = 500                                  # a reconfigure: stop, registers, start
    dev.app.apply_config(new)
    dev.app.supervisor.start(new, reprobe=True)        # a re-probe: reset, registers, start
    assert len(attached) > 20 and not any(attached), attached
    frames = dev.app.acq.state[acquisition.FRAMES]
    dev.run_until(w.time + 0.5)
    assert board._handler is not None and dev.app.acq.state[acquisition.FRAMES] >= frames + 200   # 500 SPS
    assert dev.app.supervisor.fault is None
    dev.close()
