"""`fluxcal fit` refuses on exactly the predicted error it prints (desktop/cli/fit.py).

The capture's residuals are correlated in time (AR(1), rho = 0.9: tau_int = (1 + rho) /
(1 - rho) = 19 samples in theory), so the honest predicted error, the white-noise one
widened by the correlation, is several times the white one. A --max-predicted between
them refuses only if the honest figure is the one compared; one between the printed
figure rounded up and down by its last printed digit tells whether the comparison
uses that figure and no other.
"""

import re

import numpy as np
import pytest

from desktop.cli import main
from desktop.sim.field import EARTH_NT
from desktop.sim.points import directions
from desktop.sim.sensor import Sensor

PRINTED = re.compile(r"predicted full-sphere error ([0-9.]+) nT \(([0-9.]+) nT if the residuals were independent")
# the printed figures have three decimals: half a unit of the last is the rounding,
# a whole unit puts the limit on a known side of the unrounded value
DIGIT = 1e-3


@pytest.fixture(scope="module")
def correlated_capture(tmp_path_factory):
    rng = np.random.default_rng(6)
    n, rho = 3000, 0.9
    sensor = Sensor.random(rng, 1.0, 0.005, 1000.0, 0.0)
    noise = rng.normal(0.0, 1.0, (n, 3))
    for i in range(1, n):
        noise[i] += rho * noise[i - 1]
    h = sensor.measure(EARTH_NT * directions("tumble", rng, n)) + noise * np.sqrt(1.0 - rho ** 2)  # 1 nT rms
    path = tmp_path_factory.mktemp("refusal") / "correlated.csv"
    np.savetxt(path, h, delimiter=",", header="x,y,z", comments="", fmt="%.4f")
    return path


def fit(capsys, path, out, limit):
    code = main(["fit", str(path), "-o", str(out), "--max-predicted", repr(limit)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_refusal_compares_the_printed_predicted_error(correlated_capture, tmp_path, capsys):
    code, out, err = fit(capsys, correlated_capture, tmp_path / "open.json", 1000.0)
    assert code == 0 and err == "", err
    honest, white = (float(v) for v in PRINTED.search(out).groups())
    # the case: their geometric mean is a limit at least sqrt(3) from each (sqrt(tau_int) would
    # be 4.4 for an infinite capture; the estimate of tau_int is cut off by the window)
    assert honest > 3 * white, (honest, white)

    between = (honest * white) ** 0.5
    code, out, err = fit(capsys, correlated_capture, tmp_path / "between.json", between)
    assert code == 1 and out == "" and not (tmp_path / "between.json").exists()
    assert ("predicted full-sphere error %.2f nT > %.2f nT (--max-predicted)" % (honest, between)) in err, err

    code, out, err = fit(capsys, correlated_capture, tmp_path / "below.json", honest - DIGIT)
    assert code == 1 and not (tmp_path / "below.json").exists(), out
    code, out, err = fit(capsys, correlated_capture, tmp_path / "above.json", honest + DIGIT)
    assert code == 0 and err == "" and (tmp_path / "above.json").exists(), err
    assert float(PRINTED.search(out).group(1)) == honest
