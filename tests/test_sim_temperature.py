"""The simulator's temperature: each ADS1292's reference drift and the scenario's temperature profile.

The byte-level chips carry the same drift: tests/test_sim_ads1292.py,
test_two_chips_on_one_bus_follow_the_shared_clock at 5 C. The reference drift is on by default ("seed": each chip's coefficient drawn within
+-45 ppm/C [DS §6.5]) and changes nothing at 25 C, where every pinned figure of the
other tests lives; these tests hold what it does elsewhere.
"""

import numpy as np
import pytest

from desktop.sim.ads1292 import registers as A
from desktop.sim.scenario import Scenario, simulate


def quiet(**kw):
    return Scenario(**dict(dict(seconds=0.5, rate=1000, motion="stationary", noise=0.0, adc_noise=False, seed=4),
                           **kw))


def test_each_chip_draws_its_own_reference_drift_within_the_datasheet_bound_from_the_seed():
    ks = np.array([Scenario(seed=s).vref_tempco() for s in range(200)])
    assert np.all(np.abs(ks) <= 45e-6)
    assert np.abs(ks).max() > 40e-6                         # the bound is reached, not a fraction of it
    assert len(np.unique(ks)) == ks.size                     # per chip, per seed
    assert np.array_equal(Scenario(seed=7).vref_tempco(), Scenario(seed=7, motion_seed=3).vref_tempco())
    assert np.array_equal(Scenario(seed=7, vref_drift=0).vref_tempco(), [0.0, 0.0])
    assert np.allclose(Scenario(vref_drift=(10.0, -20.0)).vref_tempco(), [10e-6, -20e-6])
    assert np.array_equal(Scenario(ideal=True).vref_tempco(), [0.0, 0.0])
    # the sensor's own errors come from the seed as before
    a, b = Scenario(seed=7).fluxgate(), Scenario(seed=7, vref_drift=0).fluxgate()
    assert np.array_equal(a.raw_model()[0], b.raw_model()[0])
    with pytest.raises(ValueError):
        Scenario(vref_drift="warm")


def test_at_25_c_the_reference_drift_changes_no_code():
    a = simulate(Scenario(seconds=0.5, rate=2000, seed=3), truth=False)["codes"]
    b = simulate(Scenario(seconds=0.5, rate=2000, seed=3, vref_drift=0), truth=False)["codes"]
    assert np.array_equal(a, b)


@pytest.mark.parametrize("temp_c", [-5.0, 10.0, 40.0])
def test_codes_follow_code_model_with_each_chips_reference(temp_c):
    """Noise-free, held still: X, Y from chip A and Z from chip B are P b + q of code_model to
    rounding; the reference's share is the ratio to a scenario without drift, the same for
    X and Y (one chip) and the chip's own for Z."""
    sc, sc0 = quiet(temp_c=temp_c), quiet(temp_c=temp_c, vref_drift=0)
    cap, cap0 = simulate(sc), simulate(sc0)
    p, q = sc.code_model(temp_c)
    pred = cap["field_true"] @ p.T + q
    assert np.max(np.abs(cap["codes"][100:, :3] - pred[100:])) <= 0.6   # rounding, and 1 kHz bandwidth
    k_a, k_b = sc.vref_tempco()
    want = 1.0 / (1.0 + np.array([k_a, k_a, k_b]) * (temp_c - 25.0))
    assert np.max(np.abs(cap["codes"][100:, :3] - cap0["codes"][100:, :3] * want)) <= 1.0   # two roundings
    assert np.max(np.abs(cap["codes"][100:, :3] - cap0["codes"][100:, :3])) > 10
    # the die temperature is read against chip B's reference too
    t = A.volts_to_temperature(A.codes_to_volts(cap["codes"][100:, 3], 1))
    assert abs(t.mean() - (A.volts_to_temperature(A.temperature_volts(temp_c) / (1 + k_b * (temp_c - 25.0)))))\
        < 0.003


def test_temperature_profile_is_piecewise_linear_and_held_at_the_ends():
    prof = [(0.2, 10.0), (0.6, 20.0), (0.8, 20.0), (1.0, 15.0)]
    sc = quiet(seconds=1.2, temp_profile=prof)
    cap = simulate(sc)
    t = cap["t"]
    want = np.interp(t, [p[0] for p in prof], [p[1] for p in prof])
    # the truth is the grid sample at each DRDY: within one grid step of the profile
    assert np.max(np.abs(cap["temperature_c"] - want)) < 25.0 / 8000 * 1.01
    assert np.allclose(sc.temperature([0.0, 0.4, 0.7, 0.9, 5.0]), [10.0, 15.0, 20.0, 17.5, 15.0])
    die = A.volts_to_temperature(A.codes_to_volts(cap["codes"][:, 3], 1))
    assert np.max(np.abs(die[10:] - want[10:])) < 0.2
    assert sc.to_dict()["temp_profile"] == [list(p) for p in prof]
    # temp_c / temp_drift still work without a profile
    assert np.allclose(Scenario(temp_c=12.0, temp_drift=3.0).temperature([0.0, 60.0]), [12.0, 15.0])


@pytest.mark.parametrize("kw", [dict(temp_profile=[(1.0, 10.0), (0.5, 12.0)]),
                                dict(temp_profile=[]),
                                dict(temp_profile=[(0.0, 200.0)]),
                                dict(temp_profile=[(0.0, 10.0)], temp_drift=1.0)])
def test_bad_temperature_profiles_are_refused(kw):
    with pytest.raises(ValueError):
        Scenario(**kw)
