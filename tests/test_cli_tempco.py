"""fluxcal tempco as a user runs it: captures at two temperatures, fitted, then coefficients.

`fluxcal simulate --temp` gives captures of one sensor (seed) at 10 C and 25 C; `fluxcal
fit` records each capture's mean die temperature; `fluxcal tempco` fits the coefficients
and attaches them to the last. They are checked against the simulator's exact DC model
(Scenario.code_model) at each temperature: offsets to the calibrations' own offset error
(a fit of 20 s at 0.1 nT: well under 0.1 nT), i.e. slopes within 0.02 nT/C over 15 C;
gains to the fits' ~1e-6: 1 ppm/C.
"""

import json

import numpy as np

from desktop.sim.scenario import Scenario
from tests.test_cli import fluxcal


def _capture_and_fit(tmp_path, temp):
    npz = str(tmp_path / ("cap%d.npz" % temp))
    r = fluxcal("simulate", "--seconds", "20", "--rate", "1000", "--seed", "5", "--temp", str(temp), "-o", npz)
    assert r.returncode == 0, r.stderr
    out = str(tmp_path / ("cal%d.json" % temp))
    r = fluxcal("fit", npz, "-o", out)
    assert r.returncode == 0, r.stderr
    cal = json.load(open(out))
    assert abs(cal["meta"]["temperature_c"] - temp) < 0.3     # the die reads to ~0.02 C
    return out


def test_tempco_from_two_fitted_captures(tmp_path):
    cold, warm = _capture_and_fit(tmp_path, 10), _capture_and_fit(tmp_path, 25)
    out = str(tmp_path / "comp.json")
    r = fluxcal("tempco", cold, warm, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "over 10." in r.stdout and "ppm/C" in r.stdout
    tc = json.load(open(out))["tempco"]
    assert tc["method"] == "calibrations" and tc["sources"] == 2
    # truth: the offsets' slope in nT (the simulator's codes times the nominal nT per code)
    sc = Scenario(seed=5, rate=1000)
    k = sc.nt_per_code()
    (p10, q10), (p25, q25) = sc.code_model(10.0), sc.code_model(25.0)
    true_o = (q25 - q10) * k / 15.0
    assert np.max(np.abs(np.array(tc["offset_per_c"]) - true_o)) < 0.02, (tc["offset_per_c"], true_o)
    # the raw axes' gains: the rows of P scale with each axis' gain
    true_g = (np.linalg.norm(p25, axis=1) / np.linalg.norm(p10, axis=1) - 1.0) / 15.0
    assert np.max(np.abs(np.array(tc["gain_per_c"]) - true_g)) < 1e-6, (tc["gain_per_c"], true_g)


def test_tempco_refuses_in_one_line(tmp_path):
    cal = _capture_and_fit(tmp_path, 25)
    r = fluxcal("tempco", cal, "-o", str(tmp_path / "x.json"))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "two or more" in r.stderr
    r = fluxcal("tempco", cal, cal, "-o", str(tmp_path / "x.json"))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "no coefficients" in r.stderr
    assert "Traceback" not in r.stderr
