"""The test harness itself: the devicesim client over a pty, and motion scripts of hours.

The issue measured a 10,000-command flood recorded as ~8,500 replies and ~430 junk lines
while the firmware wrote 10,002 clean ones: a line split across two reads was junk twice.
The client keeps the start of a line until its end arrives (Client._partial, there since
the restructuring); the flood here goes through a real pseudo-terminal to the in-process
firmware, in bursts whose replies overflow the pty so that lines do arrive split, and
every reply is accounted for. Motions: a stationary scenario of hours is two control points (it was
400 a second), built in no time and identical to the old construction; a slow hand of
hours is numpy end to end.
"""

import time

import numpy as np
import pytest

from desktop.devicesim.client import Client
from desktop.sim import motion as M
from desktop.sim.handheld import Handheld
from desktop.sim.scenario import Scenario
from tests.device_session import on_pty


class _World:
    def __init__(self):
        self.to_host = self.from_host = 0
        self.time = 0.0


class _Dev:
    def __init__(self):
        self.world = _World()

    def run_until(self, t):
        self.world.time = t


class _Ser:
    """A serial port that hands over what was written to it in pieces of 1..7 bytes a read."""

    def __init__(self, rng):
        self.buf = b""
        self.rng = rng

    def reset_input_buffer(self):
        pass

    def read(self, n):
        k = min(n, int(self.rng.integers(1, 8)))
        out, self.buf = self.buf[:k], self.buf[k:]
        return out


def test_client_assembles_lines_split_across_reads():
    ser, dev = _Ser(np.random.default_rng(1)), _Dev()
    c = Client(ser, dev)
    lines = [b'{"v": 1, "ok": true, "cmd": "version", "n": %d}\n' % i for i in range(300)]
    data = b"".join(lines)
    ser.buf = data
    dev.world.to_host = len(data)
    while c._got < len(data):
        c.step()
    assert c.junk == [] and [d["n"] for d in c.seen] == list(range(300)) and c._partial == b""


@pytest.fixture
def flood_device(tmp_path):
    with on_pty(tmp_path, 30.0, timeout=2) as wds:
        yield wds


def test_a_flood_of_ten_thousand_commands_is_answered_line_for_line(flood_device):
    """400 commands a write: their ~30 KB of replies overflow the pty (~20 KB), so the World
    hands lines over in pieces (a client that parsed each read on its own had 210 junk
    lines and 105 replies missing here, as the issue saw)."""
    w, dev, ser = flood_device
    c = Client(ser, dev, dt=0.02)
    n, per_write = 10_000, 400
    before = len(w.lines())
    split = 0                       # reads that ended inside a line
    for _ in range(n // per_write):
        c.write(b"version\n" * per_write)
        c.step()
        split += c._partial != b""
    for _ in range(300):
        if len(c.replies()) >= n:
            break
        c.step()
        split += c._partial != b""
    replies = c.replies()
    assert split > 0 and c.junk == [] and c._partial == b""
    assert len(replies) == n and all(r["ok"] and r["cmd"] == "version" for r in replies)
    # every line the firmware wrote reached the client whole: the same lines, in order
    written = w.lines()[before:]
    assert len(c.seen) == len(written) and c._got == w.to_host


def _stationary_before(seconds, rng, lever_m=0.25):
    """The stationary motion as make_motion built it before (n equal control points)."""
    n = int(np.ceil(seconds * M.CONTROL_RATE)) + 2
    t = np.arange(n) / M.CONTROL_RATE
    return M.Motion("stationary", t, np.repeat(M.random_quaternions(rng, 1), n, axis=0), lever_m=lever_m)


def test_stationary_motion_is_the_old_construction_without_its_cost():
    old = _stationary_before(30.0, np.random.default_rng(4))
    new = M.make_motion("stationary", 30.0, np.random.default_rng(4))
    t = np.concatenate([np.linspace(-1.0, 31.0, 20001), [0.0, 15.0, 30.0 + 0.0025]])
    assert np.array_equal(new.orientation(t), old.orientation(t))
    assert np.array_equal(new.position(t), old.position(t))
    start = time.process_time()
    for hours in (1, 8):
        m = M.make_motion("stationary", hours * 3600.0, np.random.default_rng(4))
        assert len(m.times) == 2 and np.array_equal(m.orientation(np.array([hours * 3600.0])), new.orientation(t[:1]))
    assert time.process_time() - start < 1.0


def _scan_before(dq):
    q = np.array(dq, dtype=float)
    s = 1
    while s < len(q):
        q[s:] = M.qmul(q[:-s], q[s:])
        s *= 2
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_prefix_scan_in_blocks_is_the_whole_scan():
    rng = np.random.default_rng(2)
    for n in (1, 2, 5, M.SCAN_BLOCK, 3 * M.SCAN_BLOCK + 17):
        dq = M.qexp(rng.standard_normal((n, 3)) * 0.05)
        dq[0] = M.random_quaternions(rng, 1)[0]
        got, ref = M.scan_product(dq), _scan_before(dq)
        if n <= M.SCAN_BLOCK:
            assert np.array_equal(got, ref)
        else:   # products associated otherwise: rounding only
            assert np.allclose(got, ref, rtol=0, atol=1e-12)


def test_hour_long_scenarios_build_in_seconds():
    """A handheld of 1 and 8 hours held still, and of an hour turned slowly by hand: the
    motion and the first chunk of analog input, as the long survey run builds them
    (Handheld `chunked`). Bounds are loose (a shared machine): the old stationary build
    alone allocated 368 MB for 8 hours; a slow hand's is numpy over 400 control points a
    second (8 hours: ~13 s of CPU here, 2 s an hour)."""
    start = time.process_time()
    for hours in (1, 8):
        hh = Handheld(Scenario(motion="stationary", seconds=hours * 3600.0, rate=1000), chunked=True)
        assert len(hh.grid["t"]) < 3 * 16000      # a few seconds of grid, not hours
    assert time.process_time() - start < 10.0
    start = time.process_time()
    hh = Handheld(Scenario(motion="hand", rot_rate=0.05, seconds=3600.0, rate=1000), chunked=True)
    assert len(hh.grid["t"]) < 3 * 16000
    rate = M.rotation_rate(hh.motion, np.array([100.0, 1800.0, 3500.0]))
    assert np.all(rate < 2 * np.pi * 0.05 * 5)                # a slow hand: about 0.05 rev/s
    assert time.process_time() - start < 30.0
