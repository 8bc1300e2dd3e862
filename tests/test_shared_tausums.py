"""shared/tausums.py: the fit's power sums at any de-lag tau from five exact accumulators.

- exact: the sums interpolated at t = p / q are, integer for integer, the power sums of the
  samples q x + p e (x de-lagged at the configured tau, e its tau step), for any rational t,
  within the nodes or far beyond them, after removals too;
- those samples are the samples de-lagged at the tau num + t dnum (shared/delag.py's unit),
  to the roundings of x and e (0.5 + |t| 0.5 units);
- the same digits on every interpreter a board has;
- the search finds the least of a residual curve and its width.
"""

import json
import os
import subprocess
from fractions import Fraction

import numpy as np
import pytest

from shared.delag import Delag, coefficients
from shared.fit import EllipsoidFit
from shared.tausums import TauSums, lagrange_sums, minimise
from tests.interpreters import INTERPRETERS, need

SCRIPT = os.path.join(os.path.dirname(__file__), "micropython", "tausums.py")
AT = [[0, 1], [3, 1], [-7, 3], [101, 64], [-250, 64], [12345, 997]]


def _job():
    """Window-2 sums of a turning field (a random walk of 2**14 steps: a fast hand) around
    1.6e6 (the handheld's 48,000 nT), the Mag648's tau with 10 % steps, at 100 samples/s."""
    rng = np.random.default_rng(4)
    s = 1600000 + np.cumsum(rng.integers(-(1 << 14), 1 << 14, size=(300, 3)), axis=0)
    samples = [[int(v) for v in row] + [i] for i, row in enumerate(s)]
    return {"taus_us": [31831, 30000, 33000], "steps_us": [3183, 3000, 3300], "rate": 1000, "decim": 10,
            "window": 2, "samples": samples, "drop": [5, 17, 200], "at": AT}


def _run(job):
    """(kept samples [(x, y, z, ex, ey, ez)], the fit, the node sums) as the firmware forms them."""
    dl = Delag(job["window"])
    dl.set_taus(job["taus_us"], job["rate"], job["decim"], job["steps_us"])
    fit, ts, kept = EllipsoidFit(), TauSums(), []
    for s in job["samples"]:
        if dl.push(*s):
            v = (dl.x, dl.y, dl.z, dl.ex, dl.ey, dl.ez)
            fit.add(*v[:3])
            ts.add(*v)
            kept.append(v)
    for i in job["drop"]:
        fit.remove(*kept[i][:3])
        ts.remove(*kept[i])
    return kept, fit, ts


def direct_sums(kept, drop, p, q):
    f = EllipsoidFit()
    for i, v in enumerate(kept):
        if i not in drop:
            f.add(q * v[0] + p * v[3], q * v[1] + p * v[4], q * v[2] + p * v[5])
    return f.sums()


@pytest.mark.parametrize("p,q", AT)
def test_interpolated_sums_are_the_sums_of_the_samples_at_that_tau(p, q):
    job = _job()
    kept, fit, ts = _run(job)
    assert lagrange_sums(fit.sums(), ts.sums(), p, q) == direct_sums(kept, job["drop"], p, q)


def test_the_samples_at_t_are_the_samples_de_lagged_at_that_tau():
    """x + t e against the unbounded de-lag with k = (num + t dnum) / 2**shift, t = -37/16."""
    job = _job()
    t = Fraction(-37, 16)
    shift, k = coefficients(job["taus_us"] + job["steps_us"], job["rate"], job["decim"])
    kept, _, _ = _run(dict(job, drop=[]))
    s = job["samples"]
    for n, v in enumerate(kept):
        m = n + 2      # kept[n] is sample n + 2 (the de-lag's two samples either side)
        for a in range(3):
            d = 8 * (s[m + 1][a] - s[m - 1][a]) - (s[m + 2][a] - s[m - 2][a])
            exact = s[m][a] + (k[a] + t * k[3 + a]) * d / (1 << shift)
            assert abs(v[a] + t * v[3 + a] - exact) <= Fraction(1, 2) + abs(t) / 2


@pytest.mark.parametrize("name", INTERPRETERS)
def test_same_sums_on_each_interpreter(name, root, tmp_path):
    job = _job()
    kept, fit, ts = _run(job)
    want = [[str(v) for v in lagrange_sums(fit.sums(), ts.sums(), p, q)] for p, q in AT]
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    proc = subprocess.run([need(name), SCRIPT, str(path), root], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["kept"] == len(kept) and out["sums"] == want


@pytest.mark.parametrize("t0", [0.0, -1.3, 2.7, -4.1])
def test_minimise_finds_the_least_and_its_width(t0):
    """rms^2 = 1 + c (t - t0)^4 (a lag left raises it by ~delta^4): the least within a grid step
    of t0 after the parabola steps, and t_sigma where n (rms^2 - 1) = 1: (1 / (n c))^(1/4)."""
    n, c = 2000, 0.01
    calls = []

    def rms_at(p, q):
        calls.append(p)
        return (1.0 + c * (p / q - t0) ** 4) ** 0.5

    t, sigma, rms = minimise(rms_at, n, -5, 5, 64, refine=6)
    assert abs(t - t0) < 0.2       # a quartic's flat bottom: the parabola steps creep towards it
    want = (1.0 / (n * c)) ** 0.25
    assert 0.5 * want < sigma < 2.0 * want
    assert len(calls) <= 16        # each is a solve on the board


def test_minimise_says_when_the_curve_does_not_rise():
    t, sigma, _ = minimise(lambda p, q: 1.0, 2000)
    assert sigma is None
