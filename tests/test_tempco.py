"""Temperature compensation: the record's "tempco", at_temperature, fit_tempco, and the
same arithmetic (WarmupFit's too) on the interpreters a board has (docs/temperature.md).
WarmupFit on CPython: tests/test_tempco_warmup.py.

Tolerances: the coefficients from noise (an ellipsoid fit of N uniform directions with
sigma per axis gives var(b_i) = 3 sigma^2 / N and a relative axis gain var 5 sigma^2 /
(F^2 N), so a line's slope var / sum (t - tm)^2 of those; checked against 20 seeds:
0.97e-3 / 0.89e-3 nT/C predicted, 2.45e-8 / 2.41e-8 per C), the interpreters' from
their float's rounding unit.
"""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from desktop.methods import fit_array, magnitudes
from desktop.sim.instrument import FIELD_NT, FRONT_END, NT_PER_CODE
from desktop.sim.points import uniform_directions
from desktop.sim.sensor import Fluxgate, Sensor
from shared import tempco as T
from shared.calibration import TEMPCO_GAIN_LIMIT, TEMPCO_OFFSET_LIMIT, Calibration
from tests.interpreters import INTERPRETERS, float_eps, need

F = 48000.0
SCRIPT = os.path.join(os.path.dirname(__file__), "micropython", "tempco.py")


def cal_with_tempco(**over):
    tc = {"t0_c": 21.5, "offset_per_c": [0.5, -0.25, 1.0], "gain_per_c": [2e-5, -3e-5, 4.5e-5],
          "range_c": [10.0, 25.0], "sources": 2, "method": "calibrations"}
    tc.update(over)
    m = [[1.01, 0.002, -0.003], [0.002, 0.99, 0.001], [-0.003, 0.001, 1.0]]
    return Calibration(m, [3400123.375, -3100456.625, 12.25], F, {"rms": 0.1}, {"temperature_c": 21.5}, tc)


# ---------------------------------------------------------------- the record
def test_record_round_trip_keeps_the_tempco_and_records_without_it_load_unchanged():
    cal = cal_with_tempco()
    d = json.loads(json.dumps(cal.to_dict()))
    back = Calibration.from_dict(d)
    assert back.tempco == cal.tempco and back.to_dict() == cal.to_dict()
    plain = Calibration(cal.matrix, cal.offset, F, meta={"temperature_c": 20.0})
    assert "tempco" not in plain.to_dict() and plain.tempco is None
    assert Calibration.from_dict(plain.to_dict()).to_dict() == plain.to_dict()
    assert Calibration.from_dict(dict(plain.to_dict(), tempco=None)).tempco is None
    # a field a newer writer adds rides along, as in meta
    d["tempco"]["gains"] = "per_axis"
    assert Calibration.from_dict(d).tempco["gains"] == "per_axis"


def test_scaled_input_scales_offset_per_c_as_the_offset():
    cal = cal_with_tempco()
    s = cal.scaled_input(0.5)
    assert s.tempco["offset_per_c"] == [0.25, -0.125, 0.5]
    assert s.tempco["gain_per_c"] == cal.tempco["gain_per_c"]
    h = np.array([[3400500.0, -3100000.0, 40000.0]])
    for t in (5.0, 21.5, 40.0):     # the same correction of the same field read as h * 0.5
        assert magnitudes(s.at_temperature(t), h * 0.5)[0] == pytest.approx(magnitudes(cal.at_temperature(t), h)[0],
                                                                            rel=1e-12)


def _set(path, value):
    def change(d):
        node = d["tempco"]
        for k in path[:-1]:
            node = node[k]
        if value is DELETE:
            del node[path[-1]]
        else:
            node[path[-1]] = value
    return change


DELETE = object()
REFUSALS = [
    ("not an object", lambda d: d.__setitem__("tempco", [1, 2]), "tempco must be a JSON object"),
] + [("no " + k, _set((k,), DELETE), "tempco has no %r" % k)
     for k in ("t0_c", "offset_per_c", "gain_per_c", "range_c", "sources", "method")] + [
    ("t0 text", _set(("t0_c",), "20"), "tempco.t0_c is not a number"),
    ("t0 bool", _set(("t0_c",), True), "tempco.t0_c is not a number"),
    ("t0 nan", _set(("t0_c",), float("nan")), "tempco.t0_c is not finite"),
    ("t0 hot", _set(("t0_c",), 131.0), "tempco.t0_c 131.0 outside"),
    ("t0 cold", _set(("t0_c",), -61.0), "tempco.t0_c -61.0 outside"),
    ("offsets 2", _set(("offset_per_c",), [1.0, 2.0]), "tempco.offset_per_c must be a list of 3"),
    ("offsets text", _set(("offset_per_c", 1), "x"), "tempco.offset_per_c[1] is not a number"),
    ("offsets inf", _set(("offset_per_c", 2), float("inf")), "tempco.offset_per_c[2] is not finite"),
    ("offsets big", _set(("offset_per_c", 0), TEMPCO_OFFSET_LIMIT * 1.01), "tempco.offset_per_c[0]"),
    ("gains big", _set(("gain_per_c", 2), -TEMPCO_GAIN_LIMIT * 1.01), "tempco.gain_per_c[2]"),
    ("gains nan", _set(("gain_per_c", 0), float("nan")), "tempco.gain_per_c[0] is not finite"),
    ("gains object", _set(("gain_per_c",), {"x": 1}), "tempco.gain_per_c must be a list of 3"),
    ("range 1", _set(("range_c",), [10.0]), "tempco.range_c must be [lo, hi]"),
    ("range text", _set(("range_c",), "10..25"), "tempco.range_c must be [lo, hi]"),
    ("range reversed", _set(("range_c",), [25.0, 10.0]), "lo above hi"),
    ("range hot", _set(("range_c", 1), 200.0), "tempco.range_c[1] 200.0 outside"),
    ("range null", _set(("range_c", 0), None), "tempco.range_c[0] is not a number"),
    ("sources float", _set(("sources",), 2.0), "tempco.sources must be an integer"),
    ("sources bool", _set(("sources",), True), "tempco.sources must be an integer"),
    ("sources 0", _set(("sources",), 0), "tempco.sources must be an integer"),
    ("method", _set(("method",), "guess"), "tempco.method must be one of"),
    ("extra nested", _set(("note",), {"a": {"b": 1}}), "tempco.note: a number, short text"),
    ("extra long", _set(("note",), "x" * 300), "tempco.note: a number, short text"),
]


@pytest.mark.parametrize("name, change, message", REFUSALS, ids=[r[0] for r in REFUSALS])
def test_every_bad_tempco_is_refused_naming_the_problem(name, change, message):
    d = cal_with_tempco().to_dict()
    change(d)
    with pytest.raises(ValueError) as e:
        Calibration.from_dict(d)
    assert message in str(e.value)


def test_the_gain_bound_keeps_every_axis_upright_across_the_temperature_range():
    cal = cal_with_tempco(gain_per_c=[TEMPCO_GAIN_LIMIT, -TEMPCO_GAIN_LIMIT, TEMPCO_GAIN_LIMIT], t0_c=-60.0,
                          range_c=[-60.0, 130.0])
    for t in (-60.0, 35.0, 130.0):
        c = cal.at_temperature(t)
        assert c.magnitude(3500000, -3000000, 1000) > 0
        assert np.linalg.det(np.array(c.matrix)) > 0


# ---------------------------------------------------------------- the model
@pytest.mark.parametrize("temp_c", [-20.0, 10.0, 21.5, 33.3, 80.0])
def test_at_temperature_is_the_model(temp_c):
    cal = cal_with_tempco()
    tc = cal.tempco
    tau = temp_c - tc["t0_c"]
    m = np.array(cal.matrix) @ np.diag(1.0 / (1.0 + np.array(tc["gain_per_c"]) * tau))
    b = np.array(cal.offset) + np.array(tc["offset_per_c"]) * tau
    rng = np.random.default_rng(1)
    h = b + rng.normal(0, 50000, (50, 3))
    c = cal.at_temperature(temp_c)
    assert c.tempco is None and c.meta["temperature_c"] == temp_c
    got = np.array([c.correct(*v) for v in h.tolist()])
    # the same model in doubles: a few roundings of 1e-16 each; a gain applied with the wrong sign
    # or temperature is off by gain_per_c x tau (up to 3e-3 of the field here), 1e6 times more
    assert np.max(np.abs(got - (h - b) @ m.T)) < 1e-9 * F
    # the offset's integer part is the record's; only the small part moved
    assert c._b_int == cal._b_int
    assert np.allclose(c._b_frac, np.array(cal._b_frac) + np.array(tc["offset_per_c"]) * tau, rtol=0, atol=1e-12)


def test_at_t0_is_the_calibration_itself_and_without_a_tempco_nothing_changes():
    cal = cal_with_tempco()
    c = cal.at_temperature(cal.tempco["t0_c"])
    for v in ([3400000, -3100000, 5], [3450000, -3050000, -40000]):
        assert c.correct(*v) == cal.correct(*v)
    plain = Calibration(cal.matrix, cal.offset, F)
    assert plain.at_temperature(40.0) is plain
    assert not plain.tempco_in_range(20.0)


def test_tempco_in_range():
    cal = cal_with_tempco(range_c=[10.0, 25.0])
    assert [cal.tempco_in_range(t) for t in (9.99, 10.0, 17.0, 25.0, 25.01)] == [False, True, True, True, False]


def test_attach_refers_the_coefficients_to_the_records_temperature():
    """The gain model (1 + g (T - t0)) / (1 + g (t1 - t0)) is 1 + g' (T - t1), exactly."""
    cal = cal_with_tempco()
    tc = dict(cal.tempco, t0_c=10.0)
    other = T.attach(Calibration(cal.matrix, cal.offset, F, meta={"temperature_c": 30.0}), tc)
    assert other.tempco["t0_c"] == 30.0 and other.tempco["offset_per_c"] == tc["offset_per_c"]
    for g, g1 in zip(tc["gain_per_c"], other.tempco["gain_per_c"]):
        for t in (0.0, 30.0, 55.0):
            assert (1 + g * (t - 10.0)) / (1 + g * 20.0) == pytest.approx(1 + g1 * (t - 30.0), rel=1e-14)
    with pytest.raises(ValueError, match="no meta.temperature_c"):
        T.attach(Calibration(cal.matrix, cal.offset, F), tc)


# ---------------------------------------------------------------- fit_tempco
def sensor_cals(fg, temps, rng, n=3000, sigma=0.3, dirs=uniform_directions):
    out = []
    for t in temps:
        r = fg.reading(F * dirs(rng, n), t) + rng.normal(0, sigma, (n, 3))
        c = fit_array(r)
        c.meta["temperature_c"] = t
        out.append(c)
    return out


@pytest.mark.parametrize("seed, temps", [(1, (10.0, 25.0)), (2, (10.0, 17.5, 25.0)), (3, (30.0, 12.0, 21.0, 5.0))])
def test_fit_tempco_recovers_the_sensors_coefficients_within_the_noise(seed, temps):
    sigma, n = 0.3, 3000
    fg = Fluxgate("mag649", seed=seed, noise_nT=sigma)
    cals = sensor_cals(fg, temps, np.random.default_rng(100 + seed), n, sigma)
    tc = T.fit_tempco(cals)
    t0 = temps[-1]
    assert tc["t0_c"] == t0 and tc["range_c"] == [min(temps), max(temps)]
    assert tc["sources"] == len(temps) and tc["method"] == "calibrations"
    stt = sum((t - np.mean(temps)) ** 2 for t in temps)
    # the sensor's raw gains (1 + k_s (T - 25)) relative to t0
    g_true = fg.tempco_scale / (1 + fg.tempco_scale * (t0 - 25.0))
    assert np.all(np.abs(np.array(tc["offset_per_c"]) - fg.tempco_offset) < 5 * math.sqrt(3 * sigma ** 2 / n / stt))
    assert np.all(np.abs(np.array(tc["gain_per_c"]) - g_true) < 5 * math.sqrt(5 * sigma ** 2 / (F ** 2 * n) / stt))
    # and compensates: the last calibration with it, over the sphere at the other temperatures
    cal = T.attach(cals[-1], tc)
    sphere = uniform_directions(np.random.default_rng(0), 2000) * F
    for t in temps:
        comp = magnitudes(cal.at_temperature(t), fg.reading(sphere, t))
        stale = magnitudes(cals[-1], fg.reading(sphere, t))
        # each calibration is predicted to ~0.017 nT rms (sigma 0.3 nT, 3000 samples); its error
        # field spans ~3.5x that over the sphere (measured 0.049-0.066 nT): 0.1 is 6x the rms
        assert np.ptp(comp) < 0.1
        if abs(t - t0) > 10:
            # over 10 C the uncompensated drift is nT (measured 8-17 nT), two orders above comp
            assert np.ptp(stale) > 10 * np.ptp(comp)


def test_fit_tempco_refuses_what_cannot_give_coefficients():
    fg = Fluxgate("mag649", seed=4)
    rng = np.random.default_rng(4)
    a, b, c = sensor_cals(fg, (10.0, 11.5, 25.0), rng, n=500)
    with pytest.raises(ValueError, match="two or more calibrations"):
        T.fit_tempco([a])
    with pytest.raises(ValueError, match="span 0.00 C"):
        T.fit_tempco([a, Calibration(a.matrix, a.offset, F, meta={"temperature_c": 10.0})])
    with pytest.raises(ValueError, match="span 1.50 C"):
        T.fit_tempco([a, b])
    with pytest.raises(ValueError, match="calibration 1 has no meta.temperature_c"):
        T.fit_tempco([a, Calibration(c.matrix, c.offset, F)])
    with pytest.raises(ValueError, match="one input unit"):
        T.fit_tempco([a, Calibration(c.matrix, c.offset, F, meta={"temperature_c": 25.0, "units": "codes"})])
    codes = c.scaled_input(1.0 / 0.0144)       # the same record in ADC codes: 69x the gain
    codes.meta = dict(c.meta)
    with pytest.raises(ValueError, match="not the same sensor, unit or site"):
        T.fit_tempco([a, codes])


# ---------------------------------------------------------------- interpreters
@pytest.fixture(scope="module")
def instrument_job(tmp_path_factory, root):
    """Three calibrations of a realistic instrument (desktop/sim/instrument.py: codes to 7.6
    million, 48,000 nT) at 10, 17 and 25 C with known drifts, fitted in CPython; a
    compensated record; spin codes at 18 C; a warm-up's integer samples. The reference run
    is CPython through the same script."""
    rng = np.random.default_rng(5)
    sensor = Sensor.random(rng, 1.0, 0.005, 300.0, 0.0)
    g = np.array([30e-6, -20e-6, 45e-6])
    o = np.array([0.5, -0.3, 0.2])

    def codes(dirs, t, noise=0.1):
        raw = sensor.measure(FIELD_NT * dirs)
        raw = (raw - sensor.offset) * (1 + g * (t - 25)) + sensor.offset + o * (t - 25)
        raw = raw + rng.normal(0, noise, raw.shape)
        return np.rint(raw / NT_PER_CODE + np.array(FRONT_END)).astype(np.int64)

    cals = []
    for t in (10.0, 17.0, 25.0):
        c = fit_array(codes(uniform_directions(rng, 4000), t).astype(float), field=FIELD_NT)
        c.meta["temperature_c"] = t
        cals.append(c)
    record = T.attach(cals[-1], T.fit_tempco(cals))
    a = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    spin = codes(np.column_stack([0.6 * np.cos(a), 0.6 * np.sin(a), np.full_like(a, 0.8)]), 18.0)
    n = 6000
    temps = 10 + 15 * np.arange(n) / n
    dirs = uniform_directions(rng, n)
    warm = np.array([codes(dirs[i:i + 1], temps[i])[0] for i in range(n)])
    job = {"cals": [c.to_dict() for c in cals], "record": record.to_dict(), "temps": [5.0, 10.0, 18.0, 25.0, 40.0],
           "codes": spin.tolist(),
           "warmup": {"samples": warm.tolist(), "temps": temps.tolist(), "scale": NT_PER_CODE}}
    path = tmp_path_factory.mktemp("tempco") / "job.json"
    path.write_text(json.dumps(job))
    return path, job, run_script(sys.executable, path, root)


def run_script(interpreter, path, root):
    # the job's lists (6,000 warm-up samples, the spin, three records) need 1.5-2 MB on a 64-bit
    # build: the unix port's default 2 MB ran out now and then (twice in fresh-clone CI runs, a
    # MemoryError printing the result); the arithmetic is the point here, not a board's heap
    proc = subprocess.run([interpreter, "-X", "heapsize=8M", SCRIPT, str(path), root], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def _slope_gain(temps):
    """max over data of |slope error| per unit error of one point: sum |t - tm| / sum (t - tm)^2."""
    t = np.asarray(temps, float)
    return np.sum(np.abs(t - t.mean())) / np.sum((t - t.mean()) ** 2)


@pytest.mark.parametrize("name", INTERPRETERS)
def test_tempco_on_the_interpreters_is_cpythons_to_their_float_width(name, instrument_job, root):
    """fit_tempco: each offset step is the difference of two offsets of ~3.4 million codes as
    the interpreter's float holds them (a half-ulp each, relative eps), each gain ratio
    about 10 half-ulps (6 squares, 2 sums, a division, the field ratio squared); a line
    turns an error d per point into at most d sum|t - tm| / sum(t - tm)^2 of slope.
    at_temperature: |h_c| within the 4 half-ulps of the field that
    test_shared_on_micropython allows without temperature, plus 3 for the column scale
    1 / (1 + g tau) (the sum, the division, the product). The warm-up's segments reach
    the solver's fixed point as CPython does up to the lines they are moved with, which
    the interpreter rounds: held to the same bounds with its segments' temperatures."""
    path, job, cp = instrument_job
    got = run_script(need(name), path, root)
    eps = float_eps(name)
    sg = _slope_gain([c["meta"]["temperature_c"] for c in job["cals"]])
    big = max(abs(v) for c in job["cals"] for v in c["offset"])
    for key, bound in (("offset_per_c", 2 * eps * big * sg), ("gain_per_c", 10 * eps * sg)):
        diff = np.abs(np.array([float(v) for v in got["tempco"][key]]) - [float(v) for v in cp["tempco"][key]])
        assert np.all(diff <= bound), (key, diff, bound)
    assert got["tempco"]["range_c"] == cp["tempco"]["range_c"] and got["tempco"]["sources"] == 3
    mag = np.array([[float(v) for v in row] for row in got["magnitude"]])
    ref = np.array([[float(v) for v in row] for row in cp["magnitude"]])
    assert np.max(np.abs(mag - ref)) <= 7 * eps * FIELD_NT
    assert got["in_range"] == cp["in_range"] == [False, True, True, True, False]
    assert got["warmup_kinds"] == cp["warmup_kinds"]
    sw = _slope_gain([10.0 + 15.0 * (k + 0.5) / len(got["warmup_kinds"]) for k in range(len(got["warmup_kinds"]))])
    for key, bound in (("offset_per_c", 2 * eps * big * sw), ("gain_per_c", 10 * eps * sw)):
        diff = np.abs(np.array([float(v) for v in got["warmup"][key]]) - [float(v) for v in cp["warmup"][key]])
        assert np.all(diff <= bound), (key, diff, bound)
