"""`fluxcal fit` refuses like the firmware, stays honest when the sensor lags, and takes a --prior."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from desktop.experiments.lag import sphere_error
from desktop.formats.calibration import load_calibration
from desktop.formats.capture import save_capture
from desktop.methods import magnitudes
from desktop.sim.field import EARTH_NT
from desktop.sim.points import directions
from desktop.sim.scenario import Scenario, simulate
from desktop.sim.sensor import Sensor
from shared import codes

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFUSED = "fluxcal: calibration refused (%s): predicted full-sphere error " % codes.PREDICTED_ERROR_TOO_HIGH


def fluxcal(*args):
    return subprocess.run([sys.executable, "-m", "desktop", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)


def one_line(text):
    lines = text.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in text, text
    return lines[0]


@pytest.fixture(scope="module")
def mag648(tmp_path_factory):
    """The issue's case: Mag648 (5 Hz) turned by hand, 120 s at 500 SPS, sensor seed 2."""
    cap = simulate(Scenario(sensor="mag648", motion="hand", seconds=120.0, rate=500, seed=2), truth=False)
    path = tmp_path_factory.mktemp("lag") / "X.npz"
    save_capture(str(path), cap)
    cap["config"] = json.loads(str(cap["config"]))
    return path, cap


def write_points(path, h):
    np.savetxt(path, h, delimiter=",", header="x,y,z", comments="", fmt="%.4f")
    return path


def test_lagging_sensor_is_refused_in_one_line_and_nothing_written(mag648, tmp_path):
    path, _ = mag648
    out = tmp_path / "cal.json"
    proc = fluxcal("fit", path, "-o", out)
    assert proc.returncode == 1 and proc.stdout == ""
    line = one_line(proc.stderr)
    assert line.startswith(REFUSED) and "> 5.00 nT" in line and "turn more slowly" in line
    assert float(line[len(REFUSED):].split()[0]) > 5.0
    assert not out.exists()


def test_accept_anyway_writes_an_honest_prediction(mag648, tmp_path):
    path, cap = mag648
    for extra, known in (([], False), (["--field", EARTH_NT], True)):
        out = tmp_path / ("known.json" if known else "fitted.json")
        proc = fluxcal("fit", path, "-o", out, "--accept-anyway", *extra)
        assert proc.returncode == 0, proc.stderr
        warning = one_line(proc.stderr)
        assert warning.startswith("fluxcal: warning: %s: predicted full-sphere error " % codes.PREDICTED_ERROR_TOO_HIGH)
        assert "written anyway (--accept-anyway)" in warning
        cal = load_calibration(str(out))
        d = cal.diagnostics
        assert d["tau_int"] > 30 and d["predicted_error_white"] < d["predicted_error"] / 5
        assert (d["systematic_floor"] > 0) == known
        assert "predicted full-sphere error %.3f nT" % d["predicted_error"] in proc.stdout
        real = sphere_error(cal, cap, field_known=known)
        # within 2x of the real full-sphere error; the white-noise value was 10-100x too small
        assert 0.5 < d["predicted_error"] / real < 2.0, (d["predicted_error"], real)
        assert d["predicted_error_white"] / real < 0.2


def test_max_predicted_sets_the_threshold(mag648, tmp_path):
    path, _ = mag648
    proc = fluxcal("fit", path, "-o", tmp_path / "cal.json", "--max-predicted", 10000)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert (tmp_path / "cal.json").exists()
    proc = fluxcal("fit", path, "-o", tmp_path / "no.json", "--max-predicted", 0)
    assert proc.returncode == 1 and "--max-predicted must be a positive" in one_line(proc.stderr)


def test_white_noise_points_keep_the_cores_prediction(tmp_path):
    rng = np.random.default_rng(4)
    s = Sensor.random(rng, 1.0, 0.005, 1000.0, 0.3)
    src = write_points(tmp_path / "raw.csv", s.measure(EARTH_NT * directions("tumble", rng, 3000), rng))
    proc = fluxcal("fit", src, "-o", tmp_path / "cal.json")
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    d = json.loads((tmp_path / "cal.json").read_text())["diagnostics"]
    assert 0.8 < d["tau_int"] < 1.3 and d["systematic_floor"] == 0.0
    assert d["predicted_error_white"] <= d["predicted_error"] <= 1.2 * d["predicted_error_white"]


def test_accept_anyway_does_not_lift_a_coverage_failure(tmp_path):
    # a 1 % cap: a predicted error of ~1,400 nT, beyond 1 % of the field, its cause the coverage
    rng = np.random.default_rng(3)
    s = Sensor.random(rng, 1.0, 0.005, 10.0, 1.0)
    src = write_points(tmp_path / "cap.csv", s.measure(EARTH_NT * directions("cap", rng, 2000, 0.01), rng))
    for extra in ([], ["--accept-anyway"]):
        out = tmp_path / "cal.json"
        proc = fluxcal("fit", src, "-o", out, *extra)
        line = one_line(proc.stderr)
        assert proc.returncode == 1 and proc.stdout == "" and not out.exists(), (extra, line)
        assert line.startswith("fluxcal: calibration failed (%s): predicted full-sphere error " % codes.DEGENERATE_COVERAGE)
        assert "a coverage failure, which --accept-anyway does not lift" in line
        assert "rotate about all three axes" in line and "turn more slowly" not in line


def test_prior_makes_a_quick_recalibration_from_a_cap(tmp_path):
    rng = np.random.default_rng(5)
    s = Sensor.random(rng, 1.0, 0.005, 1000.0, 1.0)
    full = write_points(tmp_path / "full.csv", s.measure(EARTH_NT * directions("tumble", rng, 6000), rng))
    old = tmp_path / "old.json"
    assert fluxcal("fit", full, "-o", old, "--field", EARTH_NT).returncode == 0
    s.offset = s.offset + np.array([12.0, -8.0, 15.0])          # a day's drift
    cap = write_points(tmp_path / "cap.csv", s.measure(EARTH_NT * directions("cap", rng, 3000, 0.1), rng))
    sphere = EARTH_NT * directions("uniform", rng, 20000) @ s.distortion.T + s.offset

    def error(path):
        return float(np.sqrt(np.mean((magnitudes(load_calibration(str(path)), sphere) - EARTH_NT) ** 2)))

    proc = fluxcal("fit", cap, "-o", tmp_path / "quick.json", "--prior", old)
    assert proc.returncode == 0, proc.stderr
    d = json.loads((tmp_path / "quick.json").read_text())
    assert d["meta"]["prior"] == "old.json"
    mode = d["diagnostics"].get("mode")
    assert ("prior %s: mode %s" % (old, mode) if mode else "prior %s: used as a weak prior" % old) in proc.stdout
    assert fluxcal("fit", cap, "-o", tmp_path / "alone.json", "--field", EARTH_NT, "--accept-anyway").returncode == 0
    assert error(tmp_path / "quick.json") < 0.5 * error(tmp_path / "alone.json")
    assert error(tmp_path / "quick.json") < 0.5 * error(old)           # the stale one, after the drift


@pytest.mark.parametrize("args, fragment", [
    (["--method", "algebraic"], "--prior applies to the streaming method only"),
    ([], "missing.json"),
])
def test_prior_errors_are_one_line(tmp_path, args, fragment):
    rng = np.random.default_rng(6)
    s = Sensor.random(rng, 1.0, 0.005, 10.0, 0.1)
    src = write_points(tmp_path / "raw.csv", s.measure(EARTH_NT * directions("tumble", rng, 500), rng))
    prior = tmp_path / "missing.json"
    if args:
        assert fluxcal("fit", src, "-o", tmp_path / "p.json").returncode == 0
        prior = tmp_path / "p.json"
    proc = fluxcal("fit", src, "-o", tmp_path / "out.json", "--prior", prior, *args)
    assert proc.returncode == 1 and fragment in one_line(proc.stderr)
    assert not (tmp_path / "out.json").exists()
