"""`fluxcal experiment NAME -o DIR` as the README gives it: the command writes its tables and
figure, and the tables are the ones committed in docs/experiments (the runs are seeded, so a
change of the simulator or the fit that moves them fails here until the docs are regenerated
with `fluxcal experiment all -o docs/experiments`)."""

import os

import pytest

from tests.test_cli import ROOT, fluxcal

DOCS = os.path.join(ROOT, "docs", "experiments")
WRITES = {
    "fig6": ("fig6.md",),
    "smearing": ("smearing.md", "smearing_calibration.md"),
    "lag": ("lag_shrink.md", "lag_rates.md", "lag.md", "lag_honesty.md"),
}


@pytest.mark.parametrize("name", sorted(WRITES))
def test_experiment_writes_the_committed_tables(name, tmp_path):
    r = fluxcal("experiment", name, "-o", str(tmp_path))
    assert r.returncode == 0, r.stderr
    assert "written to" in r.stdout
    assert any(f.endswith(".png") for f in os.listdir(tmp_path))
    for md in WRITES[name]:
        with open(tmp_path / md) as got, open(os.path.join(DOCS, md)) as doc:
            assert got.read() == doc.read(), "%s differs from docs/experiments: regenerate it" % md


def test_unknown_experiment_is_refused(tmp_path):
    r = fluxcal("experiment", "table9", "-o", str(tmp_path))
    assert r.returncode != 0 and "invalid choice" in r.stderr and "Traceback" not in r.stderr
