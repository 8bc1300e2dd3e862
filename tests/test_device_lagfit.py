"""device/lagfit.py: the session's tau estimate, on synthetic samples through the gates.

A slow spiral over the sphere (window-2 sums of a 48,000 nT field, 1 degree a sample: inside
the 161 deg/s gate at 100 samples/s), each sample given a tau-step term along the turn whose
size follows a turn rate that varies (a hand's). Samples that lag by t0 steps of it (x = v - t0 e,
v on the ellipsoid) have their tau found at t0; samples whose step term is nil (no turn to see)
keep the configured tau and say why.
"""

import math

import numpy as np
import pytest

from desktop.firmware.files import import_device

SCALE = 0.0144243258     # nT per code (the handheld's default)
FIELD_SUMS = 48000.0 / SCALE * 2     # |B| in window-2 sums


class FakeDelag:
    """What the gates read from shared/delag.py's Delag: taus on, and the current step terms."""
    taus_us = [31831] * 3
    ex = ey = ez = 0


def spiral(n=4000, turns=12):
    """n unit vectors along a spiral from pole to pole, and the unit tangents of the path."""
    k = np.arange(n)
    z = 1.0 - 2.0 * (k + 0.5) / n
    phi = 2 * math.pi * turns * k / n
    r = np.sqrt(1.0 - z * z)
    u = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    t = np.gradient(u, axis=0)
    return u, t / np.linalg.norm(t, axis=1)[:, None]


def run_session(t0, step_scale, calls=None, prior=None, drift=0.0):
    """The session's samples and its finish; calls: a list the finish's `between` (after each of
    the tau search's solves) and `service` (after its other long steps) are recorded in; prior: a
    calibration in force, for a quick re-calibration of samples whose offsets drifted by `drift`."""
    config = import_device("config")
    session = import_device("session")
    cfg = config.defaults()
    cfg["sensor_bandwidth_hz"] = 5.0
    cfg["cell_cap"] = 40
    s = session.Session(cfg, (SCALE,) * 3, 2, 10, prior, kind="auto" if prior is None else "quick")
    dl = FakeDelag()
    s.attach(dl)
    u, tan = spiral()
    rng = np.random.default_rng(7)
    m = np.array([[1.004, 0.01, 0.0], [0.0, 0.997, 0.0], [-0.015, 0.0, 1.001]])
    off = np.array([30000.0, 20000.0, -10000.0]) + drift
    for k in range(len(u)):
        v = m @ (FIELD_SUMS * u[k]) + off + rng.normal(0.0, 10.0, 3)   # ~0.07 nT of noise
        # the de-lag term of a 10 % tau step at a turn rate that varies between 0.5 and 1.5
        # (the sensor's own derivative: tangent to the ellipsoid the sums lie on)
        e = np.rint(step_scale * (m @ (FIELD_SUMS * tan[k])) * (1.0 + 0.5 * math.sin(k / 37.0)))
        x = np.rint(v - t0 * e)
        dl.ex, dl.ey, dl.ez = (int(c) for c in e)
        s.sample(int(x[0]), int(x[1]), int(x[2]))
    if calls is not None:        # as calibration_flow.finish wires them to the main loop's service
        s.between = lambda: calls.append(("between", s.search_solves))
        s.service = lambda: calls.append(("service", s.search_solves))
    return s, s.finish()


@pytest.mark.parametrize("t0", [-1.6, 2.3])
def test_the_lag_is_found(t0):
    s, (cal, reason, msg) = run_session(t0, 2e-3)
    assert cal is not None, (reason, msg)
    r = cal.response
    assert r["source"] == "estimated", r
    # tau = configured + t0 steps of 3183 us: within three of its own sigma and half the search's
    # grid (1/64 step, 50 us)
    want = 31831 + t0 * 3183
    sigma = r["tau_sigma_s"][0] * 1e6
    assert all(abs(t * 1e6 - want) < 3 * sigma + 25 for t in r["tau_s"]), (r, want)
    assert s.taus_us == [int(t * 1e6 + 0.5) for t in r["tau_s"]]
    # identified: its uncertainty under the configured one (response_tol, 5 % of tau)
    assert 0 < sigma < 0.05 * want, sigma


def test_no_step_to_see_keeps_the_configured_tau_and_says_so():
    s, (cal, reason, msg) = run_session(0.0, 0.0)
    assert cal is not None, (reason, msg)
    r = cal.response
    # the configured response: the sensor's 31,831 us and (delag_adc auto, the session's board not
    # polled) the sinc3's and the 2-conversion boxcar's 0.5 ms each in quadrature at 1000 SPS
    assert r["source"] == "given" and r["tau_s"] == [0.031839] * 3, r
    assert r["estimate"].startswith("not identified: the residual does not rise"), r


def test_the_finish_drains_the_ring_between_its_long_steps():
    """A Pico's DRDY ring holds 1.28 s and a finish can take longer (docs/firmware.md, "The
    finish"): the main loop's service runs after each tau-search solve, after the final solve and
    after the residual statistics, and changes nothing the session computes."""
    calls = []
    s, (cal, reason, msg) = run_session(-1.6, 2e-3, calls)
    assert cal is not None, (reason, msg)
    n = s.search_solves
    assert n >= 5, n
    # the search's solves, then the final solve's steps (shared: tests/test_shared_between.py) and
    # after it, after the residual statistics
    assert calls[:n] == [("between", k) for k in range(1, n + 1)], calls
    assert len(calls) >= n + 3 and calls[n:] == [("service", n)] * (len(calls) - n), calls
    _, (plain, _, _) = run_session(-1.6, 2e-3)
    assert (cal.matrix, cal.offset, cal.diagnostics, cal.response) == \
        (plain.matrix, plain.offset, plain.diagnostics, plain.response)


def test_a_quick_finish_drains_the_ring_inside_its_solve():
    """A quick re-calibration's final solve (gain models and the shape test: ~1.1 s of a Pico's
    1.28-s ring on its own) calls the service between its stages (shared/quick.py between)."""
    _, (first, reason, msg) = run_session(0.0, 0.0)
    assert first is not None, (reason, msg)
    calls = []
    s, (cal, reason, msg) = run_session(0.0, 0.0, calls, first, 700.0)
    assert cal is not None and cal.meta["kind"] in ("quick", "reshaped"), (reason, msg)
    # between the gain models and before the shape test, their iterations (tests/test_shared_between.py),
    # then the finish's own (after the solve, after the statistics)
    assert len(calls) >= 5 and [c[0] for c in calls] == ["service"] * len(calls), calls


def test_the_start_takes_the_gates_history_before_the_session_modules_load():
    """calibration_flow.start takes the gates' removal history (HIST_INTS ints, a session's largest
    block) before a session's modules load into the heap's holes, and the gates use it, zeroed; one
    of another length is refused: the two sizes must not drift apart (docs/limits.md)."""
    from array import array

    flow = import_device("calibration_flow")
    gates = import_device("gates")
    cfg = import_device("config").defaults()
    given = array("i", range(flow.HIST_INTS))
    g = gates.Gates(cfg, None, _Cov(), 2, 10.0, (0, 0, 0), native=False, hist=given)
    assert g.hist is given and not any(given)
    assert flow.HIST_INTS == len(gates.Gates(cfg, None, _Cov(), 2, 10.0, (0, 0, 0), native=False).hist) == 5 * gates.HIST
    with pytest.raises(ValueError):
        gates.Gates(cfg, None, _Cov(), 2, 10.0, (0, 0, 0), native=False, hist=array("i", range(10)))


class _Cov:
    _cuts = [0]
    edge = 1
    counts = None
