"""Captures round-trip through `fluxcal simulate`, `fluxcal fit` and `fluxcal correct`."""

import json

import numpy as np
import pytest

from desktop.cli import main
from desktop.formats.capture import KEYS, load_capture, load_field_nT, temperature_from_codes


@pytest.fixture(scope="module")
def captures(tmp_path_factory):
    d = tmp_path_factory.mktemp("cap")
    cal_path, spin_path = d / "cal.npz", d / "spin.npz"
    common = ["--rate", "1000", "--seed", "11", "--no-adc-noise", "--noise", "0.2"]
    assert main(["simulate", "--seconds", "20", "-o", str(cal_path), "--csv", str(d / "cal.csv"),
                 "--csv-every", "10"] + common) == 0
    assert main(["simulate", "--motion", "spin", "--seconds", "2", "--motion-seed", "5",
                 "-o", str(spin_path)] + common) == 0
    return d


def test_capture_keys_and_loader(captures):
    cap = load_capture(captures / "cal.npz")
    assert set(KEYS) <= set(cap)
    n = len(cap["t"])
    assert cap["codes"].shape == (n, 4) and cap["codes"].dtype == np.int32
    assert cap["registers"].shape == (2, 12)
    assert cap["config"]["seed"] == 11 and cap["config"]["rate"] == 1000
    h = load_field_nT(captures / "cal.npz")
    assert h.shape == (n, 3) and h.dtype == np.float64
    assert np.allclose(temperature_from_codes(cap), 25.0, atol=0.05)
    header = (captures / "cal.csv").read_text().splitlines()[0]
    assert header.split(",")[:3] == ["x", "y", "z"]


def test_fit_on_hand_capture_corrects_a_separate_spin(captures):
    cal, spin = captures / "cal.json", captures / "spin.npz"
    assert main(["fit", str(captures / "cal.npz"), "-o", str(cal)]) == 0
    assert main(["correct", str(cal), str(spin), "-o", str(captures / "out.csv")]) == 0
    out = np.genfromtxt(captures / "out.csv", delimiter=",", names=True)
    cap = load_capture(spin)
    raw = np.linalg.norm(load_field_nT(spin), axis=1)
    # the best possible: the true sensor model inverted, same noise
    a, c = cap["sensor_matrix"], cap["sensor_offset"]
    best = np.linalg.norm(np.linalg.solve(a, (load_field_nT(spin) - c).T), axis=0)
    assert np.ptp(raw) > 100 * np.ptp(best)            # uncalibrated: hundreds of nT
    assert out["magnitude"].std() < 1.2 * best.std()   # calibrated: at the noise floor
    assert np.ptp(out["magnitude"]) < 1.5 * np.ptp(best)
    assert json.loads(cal.read_text())["field"] > 40000


def test_simulate_errors_are_one_line(tmp_path, capsys):
    assert main(["simulate", "--rate", "3000", "-o", str(tmp_path / "x.npz")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("fluxcal: rate must be one of") and "\n" not in err
    assert main(["simulate", "--coverage", "0", "-o", str(tmp_path / "x.npz")]) == 1
    assert main(["simulate", "-o", str(tmp_path / "no" / "x.npz")]) == 1
    assert "directory does not exist" in capsys.readouterr().err


def test_truth_is_stored_only_when_asked(tmp_path):
    from desktop.formats.capture import TRUTH_KEYS
    plain, full = tmp_path / "plain.npz", tmp_path / "full.npz"
    common = ["--seconds", "1", "--rate", "500", "--seed", "3"]
    assert main(["simulate", "-o", str(plain), "--csv", str(tmp_path / "plain.csv")] + common) == 0
    assert main(["simulate", "-o", str(full), "--truth", "--csv", str(tmp_path / "full.csv")] + common) == 0
    a, b = load_capture(plain), load_capture(full)
    assert not set(TRUTH_KEYS) & set(a) and set(TRUTH_KEYS) <= set(b)
    assert np.array_equal(a["codes"], b["codes"])                 # the truth changes nothing measured
    n = len(b["t"])
    assert b["field_true"].shape == (n, 3) and b["quaternion"].shape == (n, 4)
    # |field_true| is |B| at the sensor: the field is uniform here
    assert np.allclose(np.linalg.norm(b["field_true"], axis=1), b["magnitude_true"], rtol=0, atol=1e-9)
    assert (tmp_path / "plain.csv").read_text().splitlines()[0] == "x,y,z,t,temperature_c"
    assert (tmp_path / "full.csv").read_text().splitlines()[0] == "x,y,z,t,temperature_c,magnitude_true"
