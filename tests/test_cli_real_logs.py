"""The command lines docs/cli.md gives for the real recordings in ../shared/data/real, run as
written: each loads its log (and the fluxgate's small cap is refused for its coverage)."""

import os
import re
import shlex
import subprocess
import sys

import pytest

from tests.shared_data import SHARED, need_shared

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "cli.md")
# folder -> (exit code, what its output says): the log loaded, its samples all read
EXPECT = {
    "hmc5883l_sunsided": (0, "8190 samples"),
    "lsm9ds1_ckexplorer": (0, "12000 samples"),
    "qmc5883l_tomisuarez": (0, "22745 samples"),
    "fluxgate_magnav_tl": (1, "calibration failed (degenerate_coverage)"),
}


def documented():
    with open(DOC, encoding="utf-8") as fh:
        lines = [line.strip() for line in fh if line.startswith("    fluxcal ") and "../shared/data/real/" in line]
    return {re.search(r"data/real/([\w-]+)/", line).group(1): line for line in lines}


def test_each_recording_has_one_documented_line():
    lines = documented()
    assert sorted(lines) == sorted(EXPECT), lines


@pytest.mark.parametrize("folder", sorted(EXPECT))
def test_the_documented_line_loads_the_recording(folder, tmp_path):
    need_shared("data", "real", folder)
    line = documented()[folder]
    # a folder beside ../shared, as the repository is, so the line runs exactly as written
    os.symlink(SHARED, tmp_path / "shared")
    (tmp_path / "repo").mkdir()
    argv = shlex.split(line)
    assert argv[0] == "fluxcal"
    env = dict(os.environ, PYTHONPATH=ROOT, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "desktop", *argv[1:]], cwd=tmp_path / "repo", env=env,
                          capture_output=True, text=True, timeout=600)
    code, fragment = EXPECT[folder]
    assert proc.returncode == code, proc.stderr
    assert fragment in proc.stdout + proc.stderr, (proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr
