"""The spike screen in integers (device/screen.py) against the float screen it replaced.

tests/micropython/screen_same.py runs both on the same streams: the simulator's (the firmware
in this process on the handheld: a turning hand, a still one, both with the ADS1292's flipped
data bits at 1e-4 per bit, and a turning hand without faults), whose window sums the screen
was pushed are recorded here, and synthetic ones (a turning field with noise, one-sample
spikes of every size, steps, reversals, random codes and the +-2**23 extremes, three scale
sets). On CPython every verdict that differs from the float screen's must be borderline:
the sample within the stated resolution of its threshold (2**-11 of the quantities plus
2**-8 nT, screen.py's docstring). On every interpreter a board has, the integer screen's
verdicts and learnt allowance must be the same as on CPython, digest for digest, and its
pushes must allocate nothing but around a spike (tests/micropython/screen_heap.py).
"""

import json
import math
import os
import subprocess
import sys

import pytest

from tests.device_session import ask, boot, configured, events
from tests.interpreters import INTERPRETERS, need

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "screen_same.py")
TOP = 1 << 23
# (motion, fault on both chips, simulated seconds)
SIM_RUNS = (("hand", "bit-flips", 30.0), ("stationary", "bit-flips", 20.0), ("hand", None, 30.0))


class Lcg:
    def __init__(self, seed):
        self.s = seed

    def next(self, bits):
        self.s = (1103515245 * self.s + 12345) & 0xFFFFFFFF
        return self.s >> (32 - bits)


def synthetic(scale, window, spike_nt):
    """(x, y, z, t) boxcar sums of `window` codes each, and a None where the stream has a gap."""
    r = Lcg(7)
    full = TOP * window
    amp = 3300000 * window      # ~48 uT at the default scale
    for turn_dps in (30.0, 360.0, 1500.0):
        w = turn_dps * math.pi / 180.0 / 100.0     # rad per sample at 100 samples/s
        for i in range(800):
            a = i * w
            noise = r.next(6) - 32
            x = int(amp * math.cos(a)) + noise
            y = int(amp * math.sin(a) * 0.9) - noise
            z = int(amp * 0.3) + (r.next(4) - 8)
            if i % 37 == 5:                   # a flipped bit 2**k in one frame of the boxcar
                bit = 1 << (8 + r.next(4))
                x += bit if r.next(1) else -bit
            if i % 53 == 11:                  # a step that stays
                z += 40000
            if i % 97 == 50:                  # a reversal of the hand
                w = -w
            yield x, y, z, i
        yield None
    for i in range(3000):                     # random codes anywhere in the range, clipped ones included
        yield ((r.next(24) - TOP) * window, (r.next(24) - TOP) * window, (r.next(24) - TOP) * window, i)
    edges = (-full, full - 1, -full + 1, 0, 1, -1, full >> 1, 8323072 * window, 8323072 * window - 1)
    for x in edges:
        for y in edges:
            for z in edges:
                yield x, y, z, 0
    for i in range(300):                      # a still field: the typical bend learnt at noise level
        yield 1000000 + r.next(3), -2000000 + r.next(3), 500000, i
    yield None
    for axis in range(3):                     # spikes a few sum units either side of spike_nt
        edge = spike_nt * window / scale[axis]
        for i in range(1080):                 # every 60th, 9 sizes, twice: the allowance decays between
            s = [1000000, -2000000, 500000, i]
            if i % 60 == 30:
                s[axis] += int(edge) + (i // 60) % 9 - 4
            yield tuple(s)


def recorded(tmp_path, motion, fault, seconds):
    """The firmware in this process on the simulated handheld: (scale, window, spike_nt) and
    every (x, y, z, t) its screen was pushed, None at each reset (a gap)."""
    w, dev = boot(tmp_path, "cpython", seconds=seconds + 1.0, motion=motion, fault=(fault, fault))
    got = []
    try:
        sc = dev.app.output.screen
        push, reset = sc.push, sc.reset

        def rec_push(x, y, z, t):
            got.append((x, y, z, t))
            return push(x, y, z, t)

        def rec_reset():
            got.append(None)
            reset()

        sc.push, sc.reset = rec_push, rec_reset
        dev.run_until(seconds)
        c = dev.app.output.cfg
        cfg = ((c["scale_x"], c["scale_y"], c["scale_z"]), c["window"], c["spike_nt"])
    finally:
        dev.close()
    return cfg, got


@pytest.fixture(scope="module")
def streams(tmp_path_factory):
    """The file of streams screen_same.py reads."""
    tmp = tmp_path_factory.mktemp("screen")
    lines = []

    def add(cfg, samples):
        (sx, sy, sz), window, spike_nt = cfg
        lines.append("cfg %r %r %r %d %r" % (sx, sy, sz, window, spike_nt))
        for s in samples:
            lines.append("gap" if s is None else "%d %d %d %d" % s)

    for i, (motion, fault, seconds) in enumerate(SIM_RUNS):
        cfg, got = recorded(tmp / ("sim%d" % i), motion, fault, seconds)
        assert len(got) > 90 * seconds
        add(cfg, got)
    for cfg in (((0.0144243258, 0.0144243258, 0.0144243258), 2, 5.0), ((0.011, 0.0173, 0.0144), 1, 0.5),
                ((1e-6, 1e3, 2.5), 64, 50.0)):
        add(cfg, synthetic(*cfg))
    path = tmp / "streams.txt"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def _run(argv, path):
    proc = subprocess.run(argv + [SCRIPT, REPO, path], capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr
    lines = [json.loads(ln) for ln in proc.stdout.splitlines()]
    return lines[:-1], lines[-1]


@pytest.fixture(scope="module")
def on_cpython(streams):
    return _run([sys.executable], streams)


def test_the_integer_screen_differs_from_the_float_one_only_at_its_threshold(on_cpython):
    per_cfg, run = on_cpython
    assert len(per_cfg) == len(SIM_RUNS) + 3
    sim = per_cfg[:len(SIM_RUNS)]
    assert sim[0]["spikes"] > 10 and sim[1]["spikes"] > 10   # the flipped bits make the screen work
    assert sum(c["spikes"] for c in per_cfg) > 100
    assert run["judged"] > 30000
    # every disagreement borderline (worst: |margin| / bound), and rare
    assert run["disagree"] == run["borderline"] and run["worst"] <= 1.0, run
    assert run["disagree"] <= 1e-3 * run["judged"], run
    assert run["accepted_differ"] == 0, run
    print(run, [(c["spikes"], c["float_spikes"]) for c in per_cfg])


@pytest.mark.parametrize("name", INTERPRETERS)
def test_the_integer_screens_verdicts_are_the_same_on(name, micropython, streams, on_cpython):
    exe = micropython if name == "micropython" else need(name)
    per_cfg, run = _run([exe], streams)
    assert run["samples"] == on_cpython[1]["samples"]
    assert [(c["spikes"], c["clipped"], c["digest"]) for c in per_cfg] == \
        [(c["spikes"], c["clipped"], c["digest"]) for c in on_cpython[0]]


@pytest.mark.parametrize("name", INTERPRETERS)
def test_the_integer_screen_allocates_nothing_but_around_a_spike_on(name, micropython, streams, on_cpython):
    """The simulator's streams pushed with the heap locked (tests/micropython/screen_heap.py): a
    turning hand without faults never allocates; with flipped bits only the pushes that judge a
    spike or have it as a neighbour (its differences past 2**30 on a 32-bit port, the exact
    bend's big integers): three a spike at most. (The 64-bit `micropython`'s small ints reach
    2**62, so there a spike's neighbours need none.)"""
    exe = micropython if name == "micropython" else need(name)
    for i, (motion, fault, _) in enumerate(SIM_RUNS):
        proc = subprocess.run([exe, os.path.join(REPO, "tests", "micropython", "screen_heap.py"), REPO,
                               streams, str(i + 1)], capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr
        got = json.loads(proc.stdout.splitlines()[-1])
        assert got["spikes"] == on_cpython[0][i]["spikes"] and got["pushes"] > 1900, got
        assert got["allocated"] <= 3 * got["spikes"], (motion, fault, got)
        if fault is None:
            assert got["allocated"] == 0, got


def test_a_one_sample_gap_is_judged_across_not_restarted():
    """A hand's to and fro (360 deg/s at most), 7,560 nT spikes (a flipped bit 2**20) every 37th
    sample, and the simulated polled board's gaps (runs of 6 and 1 between lost samples).
    Bridged (Screen.bridge at each gap; a reset let go of 3 samples in 7), the screen catches
    every spike and passes every sample the same screen passes on the stream without gaps, but
    beside a spike (a turn's apex judged across a gap is judged with 3 times the allowance, or
    it would stand out as one); its allowance, learning the bends across the gaps as a third
    and 1.5 times theirs, stays within 1.5 times that of the stream without gaps."""
    from device.screen import Screen
    scale, amp, r = (0.0144243258,) * 3, 3300000 * 2, Lcg(3)
    stream = []
    for i in range(2000):
        a = 2.0 * math.sin(math.pi * i / 100.0)
        s = [int(amp * math.cos(a)) + r.next(6) - 32, int(amp * math.sin(a) * 0.9), int(amp * 0.3), i]
        if i % 37 == 5:
            s[0] += 1 << 20
        stream.append(s)
    lost = {i for i in range(10, 1990, 9)} | {i + 2 for i in range(10, 1990, 9)}
    planted = {i for i in range(2000) if i % 37 == 5 and i not in lost}

    def run(holes):
        sc = Screen(scale, 2, 30.0, native=False)
        out, joined = set(), []
        for s in stream:
            if s[3] in holes:
                continue
            if s[3] - 1 in holes and s[3] - 2 not in holes:
                assert sc.bridge(joined.append) or sc.held() < 2
            if sc.push(*s):
                out.add(sc.t)
        return sc, out, joined

    gapless, want, _ = run(set())
    sc, out, joined = run(lost)
    assert not planted & out and len(planted) > 40
    # beside a spike: before it, and a spike judged across a gap starts the screen again
    beside = {i + d for i in planted for d in (-2, -1, 1, 2, 3, 4)}
    bad = (want - lost - out) - beside
    assert not bad and len(out) > 0.9 * (2000 - len(lost)), sorted((i, (i - 10) % 9) for i in bad)
    assert joined.count(True) > 0.9 * len(joined) > 180
    assert sc.allowance() <= 1.5 * gapless.allowance(), (sc.allowance(), gapless.allowance())


def test_a_config_change_that_leaves_the_screen_alone_keeps_it(tmp_path):
    """`config set survey_hz` (fluxcal capture's first request) rebuilt the screen: the new one
    let go of the two samples it held and, knowing no hand's bends yet, took a turning hand's
    reversal in its first samples for a spike (a capture's sample lost, tests/test_laptop_chain.py,
    1 run in 20 or so). On a turning hand, 28 such changes in 12 s lose no sample of the raw
    stream; a change of what the screen judges with (spike_nt) starts a new one."""
    w, dev = configured(tmp_path, "hand", 14.0, auto_finish=False, survey_hz=100)
    start = len(w.lines())
    ask(w, dev, "stream raw")
    changes = 0
    while w.time < 12.0:
        ask(w, dev, "config set survey_hz 100", dt=0.4)
        changes += 1
    ns = [e["n"] for e in events(w, "raw", start)]
    assert changes >= 25 and len(ns) > 1000 and ns == list(range(ns[0], ns[0] + len(ns))), (
        changes, [(a, b) for a, b in zip(ns, ns[1:]) if b != a + 1][:10])
    assert ask(w, dev, "status")["spikes"] == 0
    before = len(w.lines())
    ask(w, dev, "config set spike_nt 31", dt=0.5)
    ns = [e["n"] for e in events(w, "raw", before)]
    # a new screen: the two samples it takes before it judges one are not sent
    assert [b - a for a, b in zip(ns, ns[1:]) if b != a + 1] == [3], ns
