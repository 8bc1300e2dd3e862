"""Main-loop time against chip time: the charged cost model (hal_sim.Board.busy).

Every conversion the emulator produced is accounted for: the handler saw it,
or it is counted in `missed` (polled DRDY), and every completed block went to
the ring, was dropped (`overflow`) or thrown away (`discarded`). Tolerances
come from the arithmetic: the sim services each DRDY on its tick, so a gap is
exact; against the charged stall time it is +-1 conversion per stall (the
stall starts and ends between DRDYs).
"""

import pytest

from desktop.devicesim.costs import COSTS_S
from desktop.devicesim.procedure import calibrate_and_verify
from desktop.firmware.files import import_device
from tests.interpreters import INTERPRETERS, need
from tests.device_bounds import spin_ptp_bound

acquisition = import_device("acquisition")


class Spy:
    """Wraps the DRDY handler and account_gap of an in-process device.

    Checks, per serviced conversion, that the gap reported before it equals the
    conversions the emulator made since the last serviced one, minus one, and
    per block pushed to the ring that its `window` frames were read from
    consecutive conversions (no boxcar spans a gap).
    """

    def __init__(self, dev, world):
        self.w = world
        self.acq = acq = dev.app.acq
        self.st = acq.state
        self.gaps = []          # (conversion serviced after the gap, frames)
        self.pending = 0
        self.last = None
        self.reads = []
        self.pushed = 0
        self.spanning = 0
        self.miscounted = 0
        dev.board.attach_drdy(self.isr, dev.app.supervisor.adc.rate, self.gap)

    def gap(self, frames):
        blocks = self.st[acquisition.BLOCKS]
        self.acq.account_gap(frames)
        self.pending = frames
        if self.st[acquisition.BLOCKS] != blocks:
            self.reads = []

    def isr(self, pin):
        st, acq = self.st, self.acq
        conv = self.w.chips[0].conversions
        if self.last is not None and conv - self.last - 1 != self.pending:
            self.miscounted += 1
        self.gaps.append((conv, self.pending)) if self.pending else None
        self.last, self.pending = conv, 0
        phase, head, blocks = st[acquisition._PHASE], st[acquisition.HEAD], st[acquisition.BLOCKS]
        acq.isr(pin)
        if phase >= acq._first:
            self.reads.append(conv)
        if st[acquisition.HEAD] != head:
            self.pushed += 1
            r = self.reads
            if len(r) != acq.window or r[-1] - r[0] != acq.window - 1:
                self.spanning += 1
        if st[acquisition.BLOCKS] != blocks:
            self.reads = []


def _accounting(spy, dev):
    st, w, app = spy.st, spy.w, dev.app
    assert st[acquisition.FRAMES] == w.chips[0].conversions       # seen + missed = produced
    assert st[acquisition.BLOCKS] == (app.acq.samples + spy.acq.available() + st[acquisition.OVERFLOW]
                                  + st[acquisition.DISCARDED])
    assert spy.miscounted == 0 and spy.spanning == 0 and spy.pushed > 500


def _calibrate(tmp_path, polled=False, costs=COSTS_S, rotate_s=30.0, spin_s=10.0):
    box = {}

    def install(dev, world):
        box["spy"] = Spy(dev, world)
        box["dev"] = dev
    r = calibrate_and_verify(kind="cpython", root=str(tmp_path), rotate_s=rotate_s, spin_s=spin_s, polled=polled,
                             costs=costs, on_cal_device=install)
    return r, box["spy"], box["dev"]


def test_irq_default_costs_keep_up(tmp_path):
    """(a) MicroPython's hard IRQ, default cost model: the ring absorbs every solve (24 samples of 127)."""
    r, spy, dev = _calibrate(tmp_path)
    assert r["cal"]["state"] == "done", r["cal"]
    solves = [s for s in r["world"].stalls if s[1] == COSTS_S["solve"]]
    assert len(solves) >= 2                                # provisional solves and the final one
    st = r["cal_status"]
    assert st["overflow"] == 0 and st["missed"] == 0 and st["gaps"] == 0 and st["discarded"] == 0
    _accounting(spy, dev)
    assert not spy.gaps


def test_too_slow_a_main_loop_overflows_counted(tmp_path):
    """(b) A 2 s solve at 100 samples/s completes ~200 blocks into a ring that holds 127:
    ~73 overflows per solve, each counted, none silently lost."""
    costs = dict(COSTS_S, solve=2.0)
    r, spy, dev = _calibrate(tmp_path, costs=costs, rotate_s=15.0, spin_s=2.0)
    solves = [s for s in r["world"].stalls if s[1] == 2.0]
    st = r["cal_status"]
    assert len(solves) >= 2
    assert st["missed"] == 0                               # a hard IRQ sees every conversion
    # a stall completes 2.0 s * 100/s = 200 +- 1 blocks; the ring holds 127 at most, so
    # each stall overflows by at least 73 - 1 (more when the ring was not yet drained)
    assert st["overflow"] >= len(solves) * (200 - 127 - 1), (st, solves)
    assert 1 <= st["gaps"] <= len(solves)                  # at most one jump in block numbers per stall
    _accounting(spy, dev)


def test_polled_drdy_counts_missed_frames_and_still_calibrates(tmp_path):
    """(c) CircuitPython's polled DRDY: stalls lose conversions, counted to the frame, never mixed."""
    r, spy, dev = _calibrate(tmp_path, polled=True)
    assert r["cal"]["state"] == "done", r["cal"]
    st = r["cal_status"]
    rate = r["world"].scenario.rate
    stalls = r["world"].stalls
    # each gap against the stalls charged since the conversion serviced before it: +-1 per stall
    k = 0
    prev = 0
    for conv, frames in spy.gaps:
        group = []
        while k < len(stalls) and stalls[k][2] < conv:
            if stalls[k][2] >= prev:
                group.append(stalls[k][1])
            k += 1
        assert group, (conv, frames)                       # no gap without a stall
        assert abs(frames - sum(group) * rate) <= len(group), (conv, frames, group)
        prev = conv
    solve_gaps = [f for _, f in spy.gaps if f >= 0.24 * rate - 2]
    assert len(solve_gaps) >= 2                            # 0.24 s solves: ~240 conversions each
    assert st["missed"] == sum(f for c, f in spy.gaps if c <= st["frames"])   # those before the status
    assert st["overflow"] == 0 and st["discarded"] >= len(solve_gaps)
    _accounting(spy, dev)
    # the headline level, on the polled verification spin
    assert r["ptp_cal"] <= spin_ptp_bound(r["world"].scenario, len(r["spin_f_cal"])), r["ptp_cal"]


@pytest.mark.parametrize("name", INTERPRETERS)
def test_polled_drdy_on_each_interpreter(name, tmp_path):
    """(c) on the real interpreter: the polled board calibrates and its `missed` matches the stalls."""
    need(name)
    r = calibrate_and_verify(kind=name, root=str(tmp_path), rotate_s=30.0, spin_s=3.0, polled=True)
    assert r["cal"]["state"] == "done", r["cal"]
    st = r["cal_status"]
    stalls = [s for s in r["world"].stalls if s[2] < st["frames"]]
    charged = sum(s[1] for s in stalls) * r["world"].scenario.rate
    # each stall's conversions are whole frames: the rate x stall length rounds by < 1 per stall
    assert st["missed"] > 0 and abs(st["missed"] - charged) <= len(stalls), (st["missed"], charged, len(stalls))
    assert st["overflow"] == 0 and st["badsync"] == 0
    assert st["gaps"] >= 1 and st["discarded"] >= 1         # the solves' stalls spoil their blocks
    assert r["ptp_cal"] <= spin_ptp_bound(r["world"].scenario, len(r["spin_f_cal"])), r["ptp_cal"]


class _Counter:
    """A board whose frames carry their conversion number in X: a boxcar sum names its frames."""

    def __init__(self):
        self.conv = 0

    def spi_readinto(self, chip, buf):
        n = self.conv if chip == 0 else 0
        buf[0], buf[1], buf[2] = 0xC0, 0, 0
        buf[3], buf[4], buf[5] = (n >> 16) & 0xFF, (n >> 8) & 0xFF, n & 0xFF
        for i in range(6, 9):
            buf[i] = 0


@pytest.mark.parametrize("decim, window", [(20, 5), (7, 7), (50, 20)])
def test_account_gap_keeps_the_boxcar_on_consecutive_conversions(decim, window):
    """Gaps of every length at every phase: each block in the ring sums exactly the last
    `window` conversions of its block (block b ends at conversion (b+1)*decim - 1), and every
    block number is pushed or discarded, never both, never neither."""
    import numpy as np
    board = _Counter()
    acq = acquisition.Acquisition(board, decim, window, ring_frames=4096)
    rng = np.random.default_rng(7)
    for _ in range(40000):
        gap = 0 if rng.random() < 0.98 else int(rng.choice([1, 2, window, decim - 1, decim, 3 * decim + 1,
                                                              int(rng.integers(1, 200))]))
        board.conv += gap
        acq.account_gap(gap)
        acq.isr()
        board.conv += 1
    st = acq.state
    assert st[acquisition.FRAMES] == board.conv and st[acquisition.MISSED] > 0
    got = []
    acq.poll(lambda x, y, z, t: got.append((x, acq.last_block)), limit=acq.available())   # the sample, its block
    seen = []
    for x, blk in got:
        last = (blk + 1) * decim - 1
        assert x == sum(range(last - window + 1, last + 1)), (blk, x)
        seen.append(blk)
    assert len(seen) > 100 and len(set(seen)) == len(seen)
    assert st[acquisition.BLOCKS] == len(seen) + st[acquisition.DISCARDED] + st[acquisition.OVERFLOW]
    assert st[acquisition.BLOCKS] == board.conv // decim
