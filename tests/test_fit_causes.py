"""One predicted error for a file, in `fit` and `report` alike, and refusals that name their
cause and the fix for it (desktop/methods/refusal.py)."""

import re

import numpy as np
import pytest

from desktop.cli import main
from desktop.firmware.files import import_device
from desktop.methods import refusal
from desktop.sim.field import EARTH_NT
from desktop.sim.points import directions
from desktop.sim.sensor import Sensor
from shared import codes

PREDICTED = re.compile(r"predicted full-sphere error ([0-9.]+) nT")


def write(path, h):
    np.savetxt(path, h, delimiter=",", header="x,y,z", comments="", fmt="%.4f")
    return str(path)


@pytest.fixture(scope="module")
def drifting(tmp_path_factory):
    """A tumble whose residuals follow each other (AR(1), rho 0.95) whatever the turn rate:
    a field or a sensor that wanders, not one that lags."""
    rng = np.random.default_rng(11)
    n, rho = 3000, 0.95
    sensor = Sensor.random(rng, 1.0, 0.005, 1000.0, 0.0)
    wander = rng.normal(0.0, 1.0, n)
    for i in range(1, n):
        wander[i] += rho * wander[i - 1]
    u = directions("tumble", rng, n)
    field = EARTH_NT + 40.0 * wander * np.sqrt(1.0 - rho ** 2)     # |B| wanders by 40 nT rms
    return write(tmp_path_factory.mktemp("drift") / "drift.csv", sensor.measure(field[:, None] * u))


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_fit_and_report_give_one_predicted_error(drifting, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    code, out, err = run(capsys, "fit", drifting, "-o", tmp_path / "c.json", "--accept-anyway")
    assert code == 0, err
    fitted = float(PREDICTED.search(out).group(1))
    code, out, err = run(capsys, "report", drifting, "-o", tmp_path / "report")
    assert code == 0, err
    summary = (tmp_path / "report" / "summary.md").read_text()
    # the report's row gives the same figure to the same three decimals
    assert "| predicted full-sphere error | %.3f nT |" % fitted in summary, summary


def test_one_fit_prints_one_figure_per_name(drifting, tmp_path, capsys):
    code, out, err = run(capsys, "fit", drifting, "-o", tmp_path / "c.json", "--accept-anyway")
    assert code == 0
    text = out + err
    # each figure named once: the core's value for independent residuals, the residuals'
    # sample-to-sample noise; "white" had named both
    assert "white" not in text, text
    assert text.count("if the residuals were independent") == 1
    assert text.count("sample-to-sample noise") == 1


def test_correlated_residuals_that_ignore_the_turn_rate_are_not_called_a_lag(drifting, tmp_path, capsys):
    code, out, err = run(capsys, "fit", drifting, "-o", tmp_path / "c.json")
    assert code == 1 and not (tmp_path / "c.json").exists()
    assert err.startswith("fluxcal: calibration refused (%s): predicted full-sphere error " % codes.PREDICTED_ERROR_TOO_HIGH)
    assert "> 5.00 nT (--max-predicted)" in err
    assert "turn more slowly" not in err and "lags" not in err
    assert "but not the turn rate" in err


def test_white_noise_is_named_as_the_cause(tmp_path, capsys):
    # a noisy sensor on a full tumble: 40 nT rms over 600 samples predicts ~10 nT, over the 5 nT bar
    rng = np.random.default_rng(12)
    sensor = Sensor.random(rng, 1.0, 0.005, 1000.0, 40.0)
    src = write(tmp_path / "noisy.csv", sensor.measure(EARTH_NT * directions("tumble", rng, 600), rng))
    code, out, err = run(capsys, "fit", src, "-o", tmp_path / "c.json")
    assert code == 1, out
    assert "the noise (residual" in err and "record for longer" in err
    assert "turn more slowly" not in err and "cover" not in err


def test_the_lag_is_told_by_the_turn_rate():
    # residuals -B (tau w)^2 / 2 of a lagging sensor, against residuals of the orientation alone
    rng = np.random.default_rng(13)
    n = 4000
    angle = np.cumsum(rng.uniform(0.0, 0.1, n))                 # a turn about z at a varying rate
    u = np.column_stack([np.cos(angle), np.sin(angle), 0.3 * np.ones(n)])
    u /= np.linalg.norm(u, axis=1)[:, None]
    rate_sq = np.r_[0.0, np.sum((u[2:] - u[:-2]) ** 2, axis=1) / 4.0, 0.0]

    class Identity:
        matrix, offset, field = np.eye(3).tolist(), [0.0, 0.0, 0.0], EARTH_NT

    lagging = (EARTH_NT * (1.0 - 50.0 * rate_sq))[:, None] * u
    assert refusal.rate_correlation(Identity, lagging) < -0.9
    tilted = (EARTH_NT * (1.0 + 1e-4 * u[:, 0]))[:, None] * u    # an error of the orientation only
    assert abs(refusal.rate_correlation(Identity, tilted)) < 0.2


def test_the_coverage_minimum_is_the_firmwares():
    assert refusal.MIN_OBSERVABILITY == import_device("config").SCHEMA["min_observability"][0]


def test_status_calibrate_and_fit_name_the_figure_alike(drifting, tmp_path, capsys):
    from desktop.cli._show import fit_figures
    code, out, err = run(capsys, "fit", drifting, "-o", tmp_path / "c.json", "--accept-anyway")
    fitted = float(PREDICTED.search(out).group(1))
    # fit_figures is what status, calibrate, pull-cal and push-cal print of a calibration
    assert "predicted full-sphere error %.3f nT" % fitted in fit_figures({"predicted_error": fitted})
