"""shared/delag.py: the firmware's integer de-lag of a slow sensor (first order, tau).

- exact: every output is the sample plus round(num (8 d1 - d2) / 2**shift), ties up, as
  unbounded integers compute it, and num / 2**shift is tau f_s / 12 to half a unit of 2**-shift;
- the physics: a field turning through a 5 Hz first-order sensor, decimated, comes back
  to its length within the five-point difference's truncation;
- the same digits on every interpreter a board has, with the heap locked (small ints only),
  at the largest boxcar sums and the steps no field makes (dropped and counted).
"""

import json
import math
import os
import subprocess
from fractions import Fraction

import numpy as np
import pytest

from shared.delag import DELAY, Delag, coefficients, tau_us
from tests.interpreters import INTERPRETERS, need

SCRIPT = os.path.join(os.path.dirname(__file__), "micropython", "delag.py")


def reference(samples, taus, rate, decim):
    """(n, [x, y, z, t]) for each completed sample, in unbounded integers."""
    shift, nums = coefficients(taus, rate, decim)
    out = []
    for n in range(2, len(samples) - 2):
        v = [samples[n][a] + ((nums[a] * (8 * (samples[n + 1][a] - samples[n - 1][a])
                                          - (samples[n + 2][a] - samples[n - 2][a])) + (1 << (shift - 1))) >> shift)
             for a in range(3)]
        out.append((n, v + [samples[n][3]]))
    return out


def run_delag(samples, taus, rate, decim, window):
    dl = Delag(window)
    dl.set_taus(taus, rate, decim)
    out = []
    for i, s in enumerate(samples):
        if dl.push(*s):
            out.append((i - DELAY, [dl.x, dl.y, dl.z, dl.t]))
    return out, dl


@pytest.mark.parametrize("taus,rate,decim", [([31831] * 3, 1000, 10), ([159, 31831, 1000000], 8000, 1),
                                             ([30000, 31000, 32000], 125, 256)])
def test_coefficients_are_tau_fs_over_12_rounded(taus, rate, decim):
    shift, nums = coefficients(taus, rate, decim)
    assert 8 * max(nums) < 1 << (30 - shift)
    for t, n in zip(taus, nums):
        k = Fraction(t * rate, 12 * 10 ** 6 * decim)
        assert abs(Fraction(n, 1 << shift) - k) <= Fraction(1, 1 << (shift + 1))


def test_exact_against_unbounded_integers():
    rng = np.random.default_rng(3)
    # a random walk of window-2 boxcar sums, steps of up to 2**17 (8,000 nT: faster than a hand)
    s = np.cumsum(rng.integers(-(1 << 17), 1 << 17, size=(400, 3)), axis=0)
    samples = [[int(v) for v in row] + [i] for i, row in enumerate(s)]
    got, dl = run_delag(samples, [31831, 30000, 33000], 1000, 10, 2)
    assert dl.saturated == 0
    assert got == reference(samples, [31831, 30000, 33000], 1000, 10)


def test_a_gap_restarts_it():
    samples = [[1000 * i, -1000 * i, 7, i] for i in range(12)]
    dl = Delag(2)
    dl.set_taus([31831] * 3, 1000, 10)
    done = [dl.push(*s) for s in samples[:6]]
    dl.reset()
    done += [dl.push(*s) for s in samples[6:]]
    # five samples fill it, then every push completes the one two before it
    assert done == [False] * 4 + [True, True] + [False] * 4 + [True, True]


@pytest.mark.parametrize("rev_s", [0.5, 1.0, 3.0])
def test_a_first_order_sensor_turned_comes_back_to_its_length(rev_s):
    """A 48,000 nT field turning at rev_s through tau = 31.8 ms (the Mag648), read as window-2
    boxcar sums of 0.0144 nT codes at 100 samples/s. Lagged, the turning vector reads short
    by B (1 - 1 / sqrt(1 + (tau w)^2)): 240 nT at 0.5 rev/s, 2,100 at 3. De-lagged, the
    five-point difference reads w c with c = (8 sin wT - sin 2wT) / (6 wT) = 1 - (wT)^4 / 30,
    so |B| is short by B (tau w)^2 (wT)^4 / 30 only (0.7 nT at 3 rev/s, 1e-3 nT at 1) and the
    codes' rounding, 0.5 code times sqrt(1 + 130 (tau f_s / 12)^2) = 3.2: 0.05 nT at most."""
    tau, fs, lsb, field = 1.0 / (2 * math.pi * 5.0), 100.0, 0.0144243258, 48000.0
    w = 2 * math.pi * rev_s
    t = np.arange(200) / fs
    # the steady state of tau y' + y = b for b turning at w: b / (1 + i w tau)
    g = 1.0 / complex(1.0, w * tau)
    ang = w * t + math.atan2(g.imag, g.real)
    y = field * abs(g) * np.stack([np.cos(ang), np.sin(ang), np.zeros_like(t)], axis=1)
    sums = np.rint(2 * y / lsb).astype(np.int64)             # a window-2 boxcar sum of codes
    samples = [[int(v) for v in row] + [0] for row in sums]
    got, _ = run_delag(samples, [tau_us(tau)] * 3, 1000, 10, 2)
    mag = np.array([np.linalg.norm(v[:3]) * lsb / 2 for _, v in got])
    c = (8 * math.sin(w / fs) - math.sin(2 * w / fs)) / (6 * w / fs)
    want = field * abs(complex(1.0, w * tau * c)) * abs(g)   # the truncation, exactly
    assert field - abs(g) * field > 200.0                     # the lag it undoes
    assert want < field and field - want < 0.7                # and what it leaves (the docstring)
    assert np.max(np.abs(mag - want)) < 0.05, np.max(np.abs(mag - want))


def _extreme_job():
    """Window-64 sums near full scale, with full-scale steps no field makes (saturated)."""
    rng = np.random.default_rng(9)
    top = 64 * ((1 << 23) - 1)
    s = rng.integers(-top, top, size=(300, 3))
    s[::7] = top          # steps of up to twice the full scale
    s[3::7] = -top
    samples = [[int(v) for v in row] + [int(i % 97)] for i, row in enumerate(s)]
    calm = np.cumsum(rng.integers(-(1 << 19), 1 << 19, size=(300, 3)), axis=0)
    samples += [[int(v) for v in row] + [1] for row in calm]
    return {"taus_us": [31831, 1000000, 159], "rate": 1000, "decim": 10, "window": 64, "samples": samples}


def _bridged_job():
    """A hand's pace of window-2 sums with the polled board's one-sample holes (runs of 6 and 1)."""
    samples = _walk(400, 6)
    for i in range(5, 395, 9):
        samples[i] = samples[i + 2] = None
    return {"taus_us": [31831, 30000, 725], "rate": 1000, "decim": 10, "window": 2, "samples": samples}


@pytest.mark.parametrize("name", INTERPRETERS)
@pytest.mark.parametrize("job_of", [_extreme_job, _bridged_job])
def test_same_digits_on_each_interpreter_without_allocating(name, job_of, root, tmp_path):
    job = job_of()
    if job_of is _extreme_job:
        want, dl = run_delag(job["samples"], job["taus_us"], job["rate"], job["decim"], job["window"])
        assert dl.saturated > 50 and len(want) > 250          # both kinds of sample are in the job
    else:
        want, _, dl = run_bridged(job["samples"], job["taus_us"], job["rate"], job["decim"])
        assert len(want) > 300 and dl.saturated == 0
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    proc = subprocess.run([need(name), SCRIPT, str(path), root], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["errors"] == [] and out["saturated"] == dl.saturated
    got = [(i - DELAY, out["out"][4 * i:4 * i + 4]) for i, g in enumerate(out["got"]) if g]
    if job_of is _bridged_job:
        got = [v for _, v in got]        # in order (a bridge holds one back for a while)
    assert got == want


def bridged_reference(samples, taus, rate, decim):
    """Samples with one-sample holes (None), bridged: each hole filled with the cubic through the
    three before it and the one after, (a - 4 b + 6 c + d + 2) >> 2, then the five-point de-lag of
    every real sample with two on each side; unbounded integers. (index, [x, y, z, t]) each."""
    s = list(samples)
    for i, v in enumerate(s):
        if v is None:
            a, b, c, d = s[i - 3], s[i - 2], s[i - 1], s[i + 1]
            s[i] = [(a[k] - 4 * b[k] + 6 * c[k] + d[k] + 2) >> 2 for k in range(3)] + [c[3]]
    return [(n, v) for n, v in reference(s, taus, rate, decim) if samples[n] is not None]


def run_bridged(samples, taus, rate, decim, window=2):
    """Through Delag as the survey's Output drives it: join(True) before the sample before a
    hole. (outputs, on_hole calls as the outputs' count when called, the Delag)."""
    dl = Delag(window)
    dl.set_taus(taus, rate, decim)
    out, holes = [], []
    dl.on_hole = lambda: holes.append(len(out))
    for i, v in enumerate(samples):
        if v is None:
            continue
        if i + 1 < len(samples) and samples[i + 1] is None:
            assert dl.can_join()
            dl.join(True)
        if dl.push(*v):
            out.append([dl.x, dl.y, dl.z, dl.t])
    return out, holes, dl


def _walk(n, seed, step=1 << 17):
    s = np.cumsum(np.random.default_rng(seed).integers(-step, step, size=(n, 3)), axis=0)
    return [[int(v) for v in row] + [i] for i, row in enumerate(s)]


@pytest.mark.parametrize("pattern", [(6, 1), (4,), (3, 1, 9), (1, 1, 5, 2)])
def test_one_sample_holes_are_bridged_exactly(pattern):
    """Runs of these lengths between one-sample holes (the simulated polled board's: 6 and 1):
    every real sample with two on each side comes out, in order, exactly as the filled stream's
    five-point de-lag; on_hole once a hole, just before the first sample after it."""
    samples = _walk(300, 4)
    i, k = 5, 0                           # a run of five first: three held before the first hole
    while i < len(samples) - 3:
        samples[i] = None
        i += 1 + pattern[k % len(pattern)]
        k += 1
    taus = [31831, 30000, 33000]
    want = bridged_reference(samples, taus, 1000, 10)
    got, holes, dl = run_bridged(samples, taus, 1000, 10)
    assert dl.saturated == 0 and len(want) - 4 <= len(got) <= len(want)   # the last few still held
    assert got == [v for _, v in want[:len(got)]]
    real_before = [sum(1 for n, _ in want if n < h) for h, v in enumerate(samples) if v is None]
    assert holes == [r for r in real_before if r < len(got)]


def test_a_hole_too_early_or_two_samples_long_restarts_it():
    samples = _walk(40, 5)
    dl = Delag(2)
    dl.set_taus([31831] * 3, 1000, 10)
    dl.push(*samples[0])
    assert not dl.can_join()              # one held, one coming: no three before the hole
    holes = []
    dl.on_hole = lambda: holes.append(1)
    dl.join(True)
    assert holes == [1] and not dl.push(*samples[2])    # started again from it
    dl.reset()
    assert [dl.push(*s) for s in samples[3:10]] == [False] * 4 + [True] * 3


@pytest.mark.parametrize("rev_s,tau_s,tol_nt", [(1.0, 0.031831, 0.45), (0.5, 0.031831, 0.08), (1.0, 0.000725, 0.02)])
def test_a_bridged_field_turned_keeps_its_length(rev_s, tau_s, tol_nt):
    """A 48,000 nT field turning at rev_s through tau (the Mag648's; the whole response of a
    1 kHz sensor), window-2 sums of 0.0144 nT codes at 100 samples/s with the polled board's
    holes (runs of 6 and 1). The fill errs by B (w T)^4 / 4 along the field (0.19 nT at 1 rev/s)
    and its neighbour's de-lag term carries 8 k of it (k = tau f_s / 12): 0.4 nT for the Mag648
    at 1 rev/s, 0.025 at 0.5, 0.01 nT for tau 0.725 ms. Rounding, in sum units of 0.0072 nT: a
    sum's half unit through its de-lag, 0.5 (1 + 18 k), and the fill's, 0.5 (1/4 + 1 + 3/2 +
    1/4) + 0.5, through 8 k: at most 7.1 units (0.05 nT) for the Mag648, 0.65 (0.005 nT) else."""
    lsb, field, fs = 0.0144243258, 48000.0, 100.0
    w = 2 * math.pi * rev_s
    g = 1.0 / complex(1.0, w * tau_s)
    ang = w * np.arange(400) / fs + math.atan2(g.imag, g.real)
    y = field * abs(g) * np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=1)
    samples = [[int(v) for v in row] + [0] for row in np.rint(2 * y / lsb).astype(np.int64)]
    for i in range(10, 390, 9):
        samples[i] = samples[i + 2] = None
    got, holes, _ = run_bridged(samples, [tau_us(tau_s)] * 3, 1000, 10)
    mag = np.array([np.linalg.norm(v[:3]) * lsb / 2 for v in got])
    c = (8 * math.sin(w / fs) - math.sin(2 * w / fs)) / (6 * w / fs)
    want = field * abs(complex(1.0, w * tau_s * c)) * abs(g)
    assert len(got) > 300 and len(holes) > 70
    assert np.max(np.abs(mag - want)) < tol_nt, np.max(np.abs(mag - want))
