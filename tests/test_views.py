"""The operator's pictures without a device: the equal-area map's glyphs and legend (NO_COLOR too),
the largest gap named for a recording missing a known cap, the not-turning watch, the report's
verdict line and coverage warning, and the check that keeps a worse calibration from replacing a
better one without a word.
"""

import io
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from desktop.views.coverage_text import EMPTY, FULL, GAP, NOW, SOME, TurnWatch, guidance, map_lines
from desktop.views.sphere import SphereMap, cell_centres, describe, largest_gap
from desktop.views.verdict import coverage_counts
from shared.coverage import Coverage

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIELD = 48000.0


def fluxcal(*args):
    return subprocess.run([sys.executable, "-m", "desktop", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, timeout=300)


def sphere(n, rng):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1)[:, None]


def without_cap(axis, half_angle_deg, n=6000, seed=1):
    """Unit directions over the sphere but for a cap about `axis`."""
    u = sphere(n, np.random.default_rng(seed))
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return u[u @ a < math.cos(math.radians(half_angle_deg))]


def test_the_map_is_equal_area_and_its_squares_are_the_firmware_s_cells():
    m = SphereMap(4, cols=48, rows=12)
    cov = Coverage(4)
    for r in range(m.rows):
        for c in range(m.cols):
            d = m.direction(r, c)
            assert m.position(*d) == (r, c) and m.cell[r][c] == cov.cell(*d)
    # equal area: uniform directions fall evenly into the squares (each expects n / 576; the
    # counts are multinomial, so the spread is sqrt(n / 576) ~ 13 for n = 100,000: 6 sigma allowed)
    u = sphere(100000, np.random.default_rng(2))
    hits = np.zeros((m.rows, m.cols))
    for d in u[:100000].tolist():
        hits[m.position(*d)] += 1
    expect = len(u) / hits.size
    assert np.abs(hits - expect).max() < 6 * math.sqrt(expect), (hits.min(), hits.max(), expect)


@pytest.mark.parametrize("axis, name", [((0, 0, -1), "-Z"), ((0, 1, 0), "+Y"), ((1, 0.7, 0), "+X, towards +Y")])
def test_the_largest_gap_of_a_recording_missing_a_cap_is_named(axis, name):
    counts = coverage_counts(FIELD * without_cap(axis, 50), 4)
    gap = largest_gap(counts, 4)
    assert describe(gap.centre) == name
    line = guidance(counts, 4)
    assert ("around %s" % name) in line and "point the sensor's %s axis along" % name.split(",")[0] in line, line


def test_the_map_reads_without_colour():
    counts = [0] * 96
    centres = cell_centres(4)
    for i, d in enumerate(centres):
        if d[2] < -0.3:
            counts[i] = 24            # full at the bottom
        elif d[2] < 0.3 and d[0] > 0:
            counts[i] = 5             # some samples on the +X side of the equator
    lines = map_lines(counts, 4, 24, now=centres[0])
    body = "\n".join(lines)
    for glyph in (EMPTY, SOME, FULL, NOW, GAP):
        assert glyph in body
    assert "".join(lines[1:13]).count(NOW) == 1 and "\x1b" not in body
    assert lines[0].split() == ["-X", "-Y", "+X", "+Y", "-X"]
    assert lines[1].startswith("+Z") and lines[12].startswith("-Z")
    legend = lines[-2]
    for words in ("# full (24 samples)", "+ some", ". empty", "@ the sensor now", "* middle of the largest gap"):
        assert words in legend, legend
    # the top (around +Z) is the empty side
    assert set(lines[1][4:]) <= {EMPTY, GAP} and set(lines[12][4:]) <= {FULL, NOW}


def test_the_terminal_board_under_no_color_keeps_the_glyphs(monkeypatch):
    from rich.console import Console

    from desktop.cli._calibrate_view import coverage_map

    monkeypatch.setenv("NO_COLOR", "1")
    counts = [24] * 48 + [0] * 48
    out = io.StringIO()
    Console(file=out, force_terminal=True, width=120).print(coverage_map(counts, 4, 24, cell_centres(4)[0]))
    text = out.getvalue()
    assert "\x1b[3" not in text and "\x1b[9" not in text          # no foreground colour
    assert FULL in text and EMPTY in text and NOW in text and "the sensor now" in text


def test_turn_watch_tells_held_still_from_turning():
    watch = TurnWatch()
    rng = np.random.default_rng(3)
    for k in range(6):        # held still: a hand's wobble of about a degree
        watch.add(float(k), (1.0, 0.01 * rng.normal(), 0.01 * rng.normal()), 0.01)
    assert watch.warning().startswith("NOT TURNING") and "5 s" in watch.warning()
    watch = TurnWatch()
    for k in range(6):        # 20 degrees a second about Z, finding new cells
        a = math.radians(20 * k)
        watch.add(float(k), (math.cos(a), math.sin(a), 0.0), 0.01 * (k + 1))
    assert watch.warning() is None
    for k in range(6, 16):    # turning, but over cells already seen: coverage stays
        a = math.radians(20 * k)
        watch.add(float(k), (math.cos(a), math.sin(a), 0.0), 0.06)
    assert watch.warning().startswith("no new orientation")


def _identity_cal(path):
    path.write_text(json.dumps({"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "offset": [0, 0, 0], "field": FIELD,
                                "diagnostics": {"predicted_error": 0.2, "rms": 0.1}}))
    return path


def _csv(path, h):
    np.savetxt(path, h, delimiter=",", header="x,y,z", comments="", fmt="%.4f")
    return path


def test_report_opens_with_its_verdict_and_warns_of_a_still_recording(tmp_path):
    rng = np.random.default_rng(4)
    # held still, pointing at the middle of a cell of the +Z face (one cell of 96: 1 %)
    still = FIELD * np.array(cell_centres(4)[4 * 16 + 5]) + 0.1 * rng.normal(size=(600, 3))
    proc = fluxcal("report", _csv(tmp_path / "still.csv", still), "--cal", _identity_cal(tmp_path / "cal.json"),
                   "-o", tmp_path / "rep")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("good to 0.200 nT over the sphere; to improve: cover more of the sphere (1 % now)")
    assert "around -Z" in lines[0] and "point the sensor's -Z axis along the Earth's field" in lines[0], lines[0]
    assert lines[1].startswith("WARNING: the recording covers 1 % of the sphere"), lines[1]
    summary = (tmp_path / "rep" / "summary.md").read_text().splitlines()
    assert summary[2] == "**%s**" % lines[0] and summary[4] == "> " + lines[1]
    for png in ("coverage.png", "error_map.png", "rate.png"):
        assert (tmp_path / "rep" / png).stat().st_size > 10000


def test_report_names_the_gap_of_a_recording_missing_a_cap(tmp_path):
    rng = np.random.default_rng(5)
    # a 55 degree cap (21 % of the sphere): the cells wholly inside it are empty
    h = FIELD * without_cap((0, 1, 0), 55, n=8000) + 0.1 * rng.normal(size=(1, 3))
    proc = fluxcal("report", _csv(tmp_path / "cap.csv", h), "--cal", _identity_cal(tmp_path / "cal.json"),
                   "-o", tmp_path / "rep")
    assert proc.returncode == 0, proc.stderr
    first = proc.stdout.splitlines()[0]
    assert first.startswith("good to 0.200 nT over the sphere; to improve: fill the largest gap") and \
        "around +Y" in first, first
    assert "WARNING" not in proc.stdout


def test_a_verdict_above_what_fit_accepts_says_so_and_blames_the_scatter_not_the_recording():
    # a compass chip's ~100 nT resolution: the whole sphere turned slowly, nothing to change in the
    # recording, but the figure is above the 5 nT fit and the handheld accept (the real HMC5883L log
    # of ../shared/data/real read "good to 102.6 nT; nothing to change")
    from desktop.views.verdict import verdict
    rng = np.random.default_rng(6)
    h = sphere(6000, rng) * FIELD
    corrected = h + 250.0 * rng.normal(size=h.shape) * h / FIELD     # radial scatter, 250 nT rms
    counts = coverage_counts(corrected, 4)
    line, warnings = verdict(102.6, counts, 4, corrected, FIELD, np.arange(len(h)) * 0.01, fit_rms=245.0)
    assert line.startswith("good to 102.600 nT over the sphere (above the 5 nT `fluxcal fit` and the handheld accept)")
    assert "nothing in the recording" in line and "scatter" in line and "nothing to change" not in line, line
    assert warnings == []
    line, _ = verdict(0.2, counts, 4, corrected * 0 + h, FIELD, np.arange(len(h)) * 0.01, fit_rms=0.1)
    assert line == "good to 0.200 nT over the sphere; to improve: nothing to change: 100 % of the sphere covered, " \
                   "no error growing with the turn rate", line


class _FakeDevice:
    timeout = 2.0

    def __init__(self):
        self.asked = []

    def ask(self, line, timeout=None):
        self.asked.append(line)
        return {}


class _Args:
    auto = True
    replace = False


def test_a_calibration_held_back_as_worse_is_kept_only_when_asked(capsys):
    """The firmware held the new one back (worse_than_current): without --replace the command ends
    in one line naming both figures and the way to keep it; with it, keep-cal puts it in force."""
    from desktop.cli._errors import CommandError
    from desktop.cli.calibrate import _keep_or_not

    worse = {"state": "failed", "reason": "worse_than_current", "kind": "full", "predicted_error": 0.4,
             "current_error": 0.05, "in_force": False}
    dev = _FakeDevice()
    with pytest.raises(CommandError) as err:
        _keep_or_not(dev, worse, _Args())
    said = str(err.value)
    assert "0.400 nT is not below the 0.050 nT" in said and "--replace" in said and "\n" not in said
    assert dev.asked == []
    args = _Args()
    args.replace = True
    dev = _FakeDevice()
    kept = _keep_or_not(dev, worse, args)
    assert dev.asked == ["keep-cal"] and "kept (--replace)" in capsys.readouterr().out
    assert kept["state"] == "done" and kept["in_force"] is True


def test_a_full_coverage_png_shows_its_cells():
    """All 96 cells full: the map is not one block of colour; the cells' borders stand out."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from desktop.views.figures import coverage_figure

    fig = coverage_figure(plt, [24] * 96, 4, 24)
    fig.canvas.draw()
    rgba = np.asarray(fig.canvas.buffer_rgba())
    ax = fig.axes[0].get_window_extent()
    h = rgba.shape[0]
    inside = rgba[int(h - ax.y1) + 5:int(h - ax.y0) - 5, int(ax.x0) + 5:int(ax.x1) - 5, :3].reshape(-1, 3)
    grey = np.round(inside.mean(axis=1))
    full = np.mean(np.abs(grey - 0.3 * 255) < 20)          # the full cells' grey
    borders = np.mean(grey > 200)                            # the white outlines
    plt.close(fig)
    assert full > 0.6 and borders > 0.02, (full, borders)


def test_piped_calibrate_says_once_which_keys_finish_when_ready(capsys):
    # a terminal's board says "READY: press f or Enter"; piped, the lines said only READY, and the
    # key that finishes (a line on standard input) went unsaid
    from desktop.cli._calibrate_view import Lines
    cfg = {"min_coverage": 0.5, "target_error_nt": 1.0}
    events = [{"coverage": 0.3, "n": 100, "pred_nt": 2.0}] + [{"coverage": 0.6, "n": 300, "pred_nt": 0.5, "ready": True}] * 2
    for auto, expected in ((False, 1), (True, 0)):
        view = Lines(cfg, auto)
        for ev in events:
            view.update(ev, None)
        out = capsys.readouterr().out
        assert out.count("READY: f or Enter on standard input finishes") == expected, out
