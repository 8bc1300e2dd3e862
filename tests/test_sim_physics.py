"""Physics of the simulator with known answers: tolerances from noise, quantisation and N."""

import numpy as np
import pytest

from desktop.formats.capture import field_nT
from desktop.sim.field import EARTH_NT
from desktop.sim.motion import make_motion, rotation_rate, to_sensor, scan_product, qexp, qmul
from desktop.sim.scenario import Scenario, simulate

QUIET = dict(noise=0.0, adc_noise=False)


def test_stationary_sensor_reads_the_field_through_the_sensor_model():
    cap = simulate(Scenario(motion="stationary", seconds=0.5, seed=3, **QUIET))
    h = field_nT(cap)
    a, c = cap["sensor_matrix"], cap["sensor_offset"]
    expected = cap["field_true"] @ a.T + c
    lsb = cap["nT_per_code"]
    # only rounding to the nearest code remains (and ~1e-9 of float summation)
    assert np.all(np.abs(h - expected) <= 0.5 * lsb + 1e-6)
    assert np.ptp(h, axis=0).max() <= lsb.max()          # nothing moves


def test_perfect_sensor_in_a_spin_has_constant_magnitude_up_to_noise():
    sigma = 0.5
    cap = simulate(Scenario(motion="spin", seconds=2.0, rate=2000, ideal=True, noise=sigma,
                            adc_noise=False, motion_seed=4))
    mag = np.linalg.norm(field_nT(cap), axis=1)
    n = len(mag)
    # sinc3 makes neighbours correlated: about n/3 independent samples
    tol = 4 * np.sqrt(3.0 / (2 * n))
    assert abs(mag.std() / sigma - 1) < tol
    assert abs(mag.mean() - EARTH_NT) < 4 * sigma * np.sqrt(3.0 / n) + 0.01
    # and the raw vectors really turned around
    assert np.ptp(field_nT(cap), axis=0).min() > 10000


@pytest.mark.parametrize("window_s", [0.05, 0.1, 0.25])
def test_averaging_over_an_arc_shrinks_the_magnitude_by_sinc(window_s):
    rate, rev_s = 2000, 1.0
    cap = simulate(Scenario(motion="spin", seconds=1.2, rate=rate, ideal=True, inclination_deg=0.0,
                            rot_rate=rev_s, **QUIET))
    h = field_nT(cap)
    k = int(window_s * rate)
    blocks = h[: len(h) // k * k].reshape(-1, k, 3).mean(axis=1)
    delta = 2 * np.pi * rev_s / rate                     # angle between samples
    theta = k * delta                                    # arc of the window
    shrink = np.sin(theta / 2) / (k * np.sin(delta / 2))  # discrete form of sin(t/2)/(t/2)
    assert abs(shrink - np.sin(theta / 2) / (theta / 2)) < 1e-4
    # 0.5 LSB quantisation and the sinc3's own (microradian) arc bound the error
    assert np.allclose(np.linalg.norm(blocks, axis=1), EARTH_NT * shrink, atol=0.05)
    if window_s == 0.1:
        assert 0.015 < 1 - shrink < 0.017                # the 1.6 %


def test_hand_motion_turns_at_the_requested_rate_and_covers_the_sphere():
    m = make_motion("hand", 60.0, np.random.default_rng(2), rate=1.0)
    t = np.arange(0.1, 60.0, 0.01)
    w = rotation_rate(m, t) / (2 * np.pi)
    assert 0.8 < w.mean() < 1.2
    assert w.max() < 3.0 + 1e-6                          # the wrist's soft limit
    d = to_sensor(m.orientation(t), np.array([1.0, 0.0, 0.0]))
    assert np.all(np.abs(d.mean(axis=0)) < 0.3)          # no stuck hemisphere


@pytest.mark.parametrize("coverage", [0.1, 0.5])
def test_cap_coverage_limits_the_field_directions(coverage):
    fdir = np.array([0.6, 0.0, 0.8])
    for name in ("hand", "cap"):
        m = make_motion(name, 30.0, np.random.default_rng(1), coverage=coverage, field_dir=fdir)
        d = to_sensor(m.orientation(np.arange(0, 30.0, 0.05)), fdir)
        theta = np.arccos(1 - 2 * coverage)               # cap half-angle
        # all directions within theta of one centre: no two further apart than 2 theta
        assert np.arccos(np.clip(d @ d.T, -1, 1)).max() <= 2 * theta + 1e-9
        # and the motion explores most of it
        assert np.arccos(np.clip(d @ d.T, -1, 1)).max() > 1.5 * theta


def test_prefix_scan_integration_equals_sequential_product():
    rng = np.random.default_rng(0)
    dq = qexp(rng.normal(0, 0.1, (1000, 3)))
    seq = [dq[0]]
    for k in range(1, len(dq)):
        seq.append(qmul(seq[-1], dq[k]))
    assert np.allclose(scan_product(dq), np.array(seq), atol=1e-12)


def test_sensor_bandwidth_attenuates_the_rotating_field():
    # a 5 Hz first-order sensor spun at 1 rev/s: |H| = 1/sqrt(1 + (1/5)^2) = 0.9806
    cap = simulate(Scenario(motion="spin", seconds=3.0, rate=1000, ideal=True, inclination_deg=0.0,
                            bandwidth=5.0, **QUIET))
    mag = np.linalg.norm(field_nT(cap), axis=1)[1000:]  # after the filter's start
    assert np.allclose(mag, EARTH_NT / np.sqrt(1 + 0.2 ** 2), atol=0.5)


def test_gradient_and_dipole_change_the_true_field():
    cap = simulate(Scenario(seconds=4.0, rate=500, gradient=50.0, **QUIET))
    assert 0.1 < np.ptp(cap["magnitude_true"]) < 50.0 * 1.0
    cap = simulate(Scenario(seconds=4.0, rate=500, dipole={"distance_m": 5.0, "t_closest_s": 2.0,
                                                           "speed_m_s": 5.0}, **QUIET))
    # 300 A m^2 at 5 m: up to 2 x 100 x 300 / 125 = 480 nT
    assert 50 < np.ptp(cap["magnitude_true"]) < 500


def test_seed_fixes_the_sensor_independently_of_motion_and_duration():
    a = simulate(Scenario(seconds=1.0, seed=7, motion_seed=1))
    b = simulate(Scenario(seconds=3.0, seed=7, motion_seed=2, motion="spin"))
    c = simulate(Scenario(seconds=1.0, seed=8, motion_seed=1))
    assert np.array_equal(a["sensor_matrix"], b["sensor_matrix"])
    assert np.array_equal(a["sensor_offset"], b["sensor_offset"])
    assert not np.array_equal(a["sensor_matrix"], c["sensor_matrix"])
    assert np.array_equal(a["quaternion"], c["quaternion"])      # same motion seed, same motion
