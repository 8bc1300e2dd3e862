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


@pytest.mark.parametrize("name", INTERPRETERS)
def test_same_digits_on_each_interpreter_without_allocating(name, root, tmp_path):
    job = _extreme_job()
    want, dl = run_delag(job["samples"], job["taus_us"], job["rate"], job["decim"], job["window"])
    assert dl.saturated > 50 and len(want) > 250          # both kinds of sample are in the job
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    proc = subprocess.run([need(name), SCRIPT, str(path), root], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["errors"] == [] and out["saturated"] == dl.saturated
    got = [(i - DELAY, out["out"][4 * i:4 * i + 4]) for i, g in enumerate(out["got"]) if g]
    assert got == want
