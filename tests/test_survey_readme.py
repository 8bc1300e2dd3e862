"""The README's walked survey, run as written: a hand calibration, two simulated walks, three maps."""

import os
import re
import shlex

from desktop.cli import main
from tests.docs_index import ROOT


def _survey_commands():
    text = open(os.path.join(ROOT, "README.md"), encoding="utf-8").read()
    block = text[text.index("A walked survey over buried iron"):text.index("python -m desktop.bench.survey")]
    lines = [ln.strip() for ln in block.splitlines() if ln.strip().startswith("fluxcal ")]
    return [cmd.strip() for ln in lines for cmd in re.split(r"&&", ln)]


def test_readme_survey_runs_as_written(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    commands = _survey_commands()
    assert any("--motion survey" in c for c in commands) and any(c.startswith("fluxcal map") for c in commands)
    for cmd in commands:
        argv = shlex.split(cmd)
        assert argv[0] == "fluxcal"
        assert main(argv[1:]) == 0, cmd
    out = capsys.readouterr().out
    for d in ("raw", "cal", "ideal"):
        assert all(os.path.getsize(os.path.join(d, f)) > 0 for f in ("map.png", "grid.csv", "anomalies.csv"))
    # the calibrated map finds anomalies, the uncalibrated one's heading error buries them
    assert "calibrated by cal.json" in out and os.path.exists("site.json")
