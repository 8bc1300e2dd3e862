"""shared/ on the real MicroPython interpreter, and every firmware file through mpy-cross."""

import glob
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from tests.scenarios import FIELD, LSB, scenario

SCRIPT = os.path.join(os.path.dirname(__file__), "micropython", "run_fit.py")


def run(interpreter, job, root, tmp_path):
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    proc = subprocess.run([interpreter, SCRIPT, str(path), root], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def job_for(raw, field=None):
    return {"points": np.rint(raw / LSB).astype(np.int64).tolist(), "field": field, "scale": LSB}


@pytest.mark.parametrize("case", [
    dict(seed=0, kind="uniform", field=None),
    dict(seed=1, kind="tumble", field=FIELD),
    dict(seed=2, kind="cap", field=None),
])
def test_micropython_gives_the_cpython_result(case, micropython, root, tmp_path):
    raw, _, _ = scenario(case["seed"], case["kind"], coverage=0.4, n=1500)
    job = job_for(raw, case["field"])
    mp = run(micropython, job, root, tmp_path)
    cp = run(sys.executable, job, root, tmp_path)
    # Exact power sums: identical digits on both interpreters.
    assert mp["sums"] == cp["sums"]
    # Both unix builds compute in IEEE double; big ints reach floats through
    # the same exact 53-bit conversion, so the solve is identical too.
    a, b = mp["calibration"], cp["calibration"]
    assert a["matrix"] == b["matrix"]
    assert a["offset"] == b["offset"]
    assert a["field"] == b["field"]


@pytest.mark.parametrize("n, expected", [(8, "too_few_samples"), (1500, "degenerate_coverage")])
def test_micropython_reports_reasons(n, expected, micropython, root, tmp_path):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    circle = np.column_stack([FIELD * np.cos(t), FIELD * np.sin(t), np.zeros(n)])
    assert run(micropython, job_for(circle), root, tmp_path)["reason"] == expected


def firmware_files(root):
    files = sorted(glob.glob(os.path.join(root, "shared", "*.py")) + glob.glob(os.path.join(root, "device", "**", "*.py"), recursive=True))
    assert any(f.endswith("fit.py") for f in files)
    return files


def test_every_shared_and_device_file_compiles_with_mpy_cross(mpy_cross, root, tmp_path):
    failures = []
    for path in firmware_files(root):
        out = tmp_path / (os.path.basename(path)[:-3] + ".mpy")
        proc = subprocess.run([mpy_cross, "-o", str(out), path], capture_output=True, text=True)
        if proc.returncode != 0 or not out.exists():
            failures.append("%s: %s" % (path, proc.stderr.strip()))
    assert not failures, "\n".join(failures)
