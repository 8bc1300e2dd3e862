"""`fluxcal fit` / `fluxcal correct` as a user runs them: a real subprocess."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from tests.scenarios import FIELD, scenario

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def fluxcal(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "desktop", *args], capture_output=True, text=True, cwd=cwd or ROOT, timeout=300)


def write_csv(path, h, extra=True):
    with open(path, "w") as fh:
        fh.write("t,x,y,z,note\n" if extra else "x,y,z\n")
        for i, (x, y, z) in enumerate(np.asarray(h, dtype=float).tolist()):
            fh.write(("%d,%.4f,%.4f,%.4f,ok\n" % (i, x, y, z)) if extra else ("%.4f,%.4f,%.4f\n" % (x, y, z)))


@pytest.mark.parametrize("method", ["streaming", "algebraic", "mle", "paper-nn"])
def test_fit_then_correct_round_trip(method, tmp_path):
    raw, _, _ = scenario(0, "tumble", n=2000, noise=0.1)
    src = tmp_path / "raw.csv"
    write_csv(src, raw)
    cal = tmp_path / "cal.json"
    out = tmp_path / "out.csv"
    proc = fluxcal("fit", str(src), "-o", str(cal), "--method", method, "--field", str(FIELD))
    assert proc.returncode == 0, proc.stderr
    d = json.loads(cal.read_text())
    assert len(d["matrix"]) == 3 and len(d["offset"]) == 3 and d["field"] == FIELD
    proc = fluxcal("correct", str(cal), str(src), "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert table.shape == (len(raw), 4)
    assert np.allclose(np.linalg.norm(table[:, :3], axis=1), table[:, 3], atol=1e-3)
    # h_c = matrix (h - offset) exactly as the JSON says.
    expect = (raw - d["offset"]) @ np.array(d["matrix"]).T
    assert np.allclose(table[:, :3], expect, atol=1e-3)
    if method != "paper-nn":  # the paper's method cannot remove gain errors (README)
        assert np.std(table[:, 3]) < 0.2


def test_float32_flag(tmp_path):
    raw, _, _ = scenario(1, n=1500)
    src = tmp_path / "raw.csv"
    write_csv(src, raw, extra=False)
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert fluxcal("fit", str(src), "-o", str(a)).returncode == 0
    assert fluxcal("fit", str(src), "-o", str(b), "--float32").returncode == 0
    ma, mb = np.array(json.loads(a.read_text())["matrix"]), np.array(json.loads(b.read_text())["matrix"])
    assert np.max(np.abs(ma - mb)) < 1e-6  # float32 storage of entries ~1


def bad(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("name, text, fragment", [
    ("missing.csv", "a,b,c\n1,2,3\n", "no column for x in the header (a,b,c)"),
    ("empty.csv", "", "empty file"),
    ("header_only.csv", "x,y,z\n", "no data rows"),
    ("few.csv", "x,y,z\n" + "1,2,3\n" * 5, "5 rows, need at least 12"),
    ("nan.csv", "x,y,z\n" + "1,2,3\n" * 20 + "nan,1,2\n", "row 21 is not finite"),
    ("text.csv", "x,y,z\n1,2,three\n", "line 2: expected numbers"),
    ("flat.csv", "x,y,z\n" + "".join("%d,%d,0\n" % (i, 2 * i) for i in range(20000, 70000, 1000)),
     "calibration failed (degenerate_coverage)"),
])
def test_bad_input_is_one_line_and_exit_1(tmp_path, name, text, fragment):
    proc = fluxcal("fit", bad(tmp_path, name, text), "-o", str(tmp_path / "cal.json"))
    assert proc.returncode == 1
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("fluxcal: ")
    assert fragment in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "cal.json").exists()


def test_missing_file_and_bad_calibration(tmp_path):
    proc = fluxcal("fit", str(tmp_path / "nope.csv"), "-o", str(tmp_path / "c.json"))
    assert proc.returncode == 1 and "no such file" in proc.stderr
    raw = bad(tmp_path, "raw.csv", "x,y,z\n" + "1,2,3\n" * 20)
    for text, fragment in [("{", "not JSON"), ('{"matrix": [[1,0,0],[0,1,0],[0,0,1]], "offset": [0,0], "field": 1}', "offset must be a list of 3")]:
        proc = fluxcal("correct", bad(tmp_path, "cal.json", text), raw, "-o", str(tmp_path / "o.csv"))
        assert proc.returncode == 1 and fragment in proc.stderr and proc.stderr.count("\n") == 1


def test_demo_runs_the_firmware_on_the_simulated_handheld(tmp_path):
    """`make demo` runs `fluxcal demo`: the firmware in micropython calibrates and verifies."""
    make = open(os.path.join(ROOT, "Makefile")).read()
    assert "\t$(BIN)/fluxcal demo\n" in make
    proc = fluxcal("demo", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "firmware in micropython" in proc.stdout
    row = [ln for ln in proc.stdout.splitlines() if ln.startswith("| this firmware (micropython)")]
    ptp = float(row[0].split("|")[2])
    from desktop.sim.scenario import Scenario
    from tests.device_bounds import DEFAULTS, spin_ptp_bound
    assert ptp <= spin_ptp_bound(Scenario(rate=DEFAULTS["rate"]), 100), ptp
    assert (tmp_path / "device_spin.png").exists() and (tmp_path / "device_coverage.png").exists()
    # and again, as a user runs `make demo` twice: a fresh board, not the first run's calibration in force
    again = fluxcal("demo", "--out", str(tmp_path))
    assert again.returncode == 0, again.stdout[-2000:] + again.stderr[-2000:]


def test_core_demo_reaches_the_noise_floor():
    proc = fluxcal("demo", "--core-only")
    assert proc.returncode == 0, proc.stderr
    labels = ("noise floor (true parameters)", "streaming (shared/, double)", "streaming (shared/, float32)")
    rows = {ln[:32].strip(): [float(v) for v in ln[32:].split()[:2]] for ln in proc.stdout.splitlines()
            if ln[:32].strip() in labels}
    floor_var = rows["noise floor (true parameters)"][1]
    # variance of 3600 spin samples scatters by sqrt(2/3600) = 2.4 %: the calibration may add 4 of those
    for label in ("streaming (shared/, double)", "streaming (shared/, float32)"):
        assert rows[label][1] <= floor_var * (1 + 4 * np.sqrt(2 / 3600)), (label, rows[label], floor_var)
