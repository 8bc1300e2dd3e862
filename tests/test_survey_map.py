"""fluxcal map: positions from markers and pace, the processing steps, anomalies placed by their fit."""

import csv

import numpy as np

from desktop.cli import main
from desktop.sim.field import earth_vector
from desktop.sim.site import Site
from desktop.survey.anomalies import find_anomalies
from desktop.survey.gridding import interpolate
from desktop.survey.processing import destripe, drift, process, stripes_nT
from desktop.survey.traverses import Grid, Traverse, traverses

FDIR = earth_vector(1.0)


def test_positions_spread_evenly_between_the_marks():
    grid = Grid(width_m=1.0, length_m=10.0, spacing_m=0.5, zigzag=True)
    t = np.arange(0, 30, 0.004)
    marks = np.array([[1.0, 11.0], [15.0, 25.0]])
    # the field rises 2 nT per metre north; the walker at 1 m/s, south on the second line
    north = np.where(t < 13, t - 1.0, 10.0 - (t - 15.0))
    lines = traverses(t, 47000.0 + 2.0 * north, marks, grid, sample_m=0.5)
    for ln in lines:
        # a bin's mean of a linear field is the field at its centre (to the 4 ms sampling)
        assert np.allclose(ln.nT - 47000.0, 2.0 * ln.north_m, atol=2.0 * 0.004)
    assert [ln.east_m for ln in lines] == [0.25, 0.75]


def _lines(levels, n=80):
    return [Traverse(i, 0.5 * i + 0.25, np.arange(n) * 0.125, np.full(n, float(v)), 10.0 * i + np.arange(n) * 0.1,
                     i % 2 == 0) for i, v in enumerate(levels)]


def test_drift_keeps_the_stripes_destripe_removes_them():
    k = np.arange(20)
    # a cubic drift in time (removed exactly) plus +-0.8 nT alternation (heading error)
    t_mid = 10.0 * k + 3.95
    levels = 1e-4 * (t_mid - 50) ** 3 / 10 + 0.02 * t_mid + 0.8 * (-1) ** k
    lines = _lines(levels)
    for ln in lines:               # the drift also runs within each line: the same cubic in time
        ln.nT = 1e-4 * (ln.t_s - 50) ** 3 / 10 + 0.02 * ln.t_s + 0.8 * (-1) ** ln.index
    drift(lines)
    # the alternation of +-0.8 nT survives (a cubic cannot follow it): rms 0.8 less what the
    # least squares takes with it (4 of 20 degrees of freedom at most)
    assert 0.8 * np.sqrt(16 / 20) * 0.95 < stripes_nT(lines) < 0.8 * 1.01
    destripe(lines)
    assert stripes_nT(lines) < 1e-9


def test_steps_switch_off_and_report():
    lines = _lines([1.0, 3.0, 1.0, 3.0])
    report = process(lines, steps=("despike",))
    assert report[0].startswith("level") and report[2] == "drift: off" and report[3] == "destripe: off"
    assert abs(stripes_nT(lines) - 1.0) < 1e-9


def test_a_dipole_is_placed_and_its_depth_found():
    depth, north, east = 0.8, 6.2, 4.4
    site = Site(10, 12, [{"kind": "tool", "x": north, "y": east, "depth": depth, "moment": 0.5 * FDIR}],
                None, 0.0, 0.0, 0)
    grid = Grid(10.0, 12.0, 0.5, True)
    lines = []
    for i in range(20):
        n = np.arange(96) * 0.125 + 0.0625
        pts = np.c_[n, np.full(96, 0.25 + 0.5 * i), np.full(96, -0.3)]
        lines.append(Traverse(i, 0.25 + 0.5 * i, n, site.objects_field(pts) @ FDIR, n, True))
    mg = interpolate(lines, grid)
    samples = np.concatenate([np.c_[ln.north_m, np.full(96, ln.east_m), ln.nT] for ln in lines])
    found, threshold = find_anomalies(mg, samples, FDIR, 0.3, threshold_nT=1.0)
    assert len(found) == 1 and found[0].kind == "compact"
    a = found[0]
    # noise-free and the same dipole model: the fit stops at LM's 1e-4 m step
    assert np.hypot(a.north_m - north, a.east_m - east) < 0.01 and abs(a.depth_fit_m - depth) < 0.01
    # the peak itself sits south of the source (inclined field): why the fit is needed
    assert a.peak_north_m < north - 0.05
    # the half-width rule (a sphere's, for a pole-reduced anomaly) within 30 %
    assert abs(a.depth_halfwidth_m - depth) < 0.3 * (depth + 0.3)


def test_cli_maps_a_simulated_survey(tmp_path, capsys):
    cap, out = tmp_path / "s.npz", tmp_path / "map"
    assert main(["simulate", "--motion", "survey", "--grid", "8x8", "--line-spacing", "0.5", "--zigzag",
                 "--site", "2", "--ideal", "-o", str(cap)]) == 0
    assert main(["map", str(cap), "-o", str(out), "--no-despike"]) == 0
    text = capsys.readouterr().out
    assert "despike: off" in text and "destripe: each traverse" in text
    assert (out / "map.png").stat().st_size > 10000
    head = (out / "grid.csv").read_text().splitlines()[:4]
    assert head[0].startswith("# fluxcal map grid") and head[3] == "east_m,north_m,nT"
    rows = list(csv.DictReader(open(out / "anomalies.csv")))
    assert rows and {"north_m", "east_m", "peak_nT", "depth_halfwidth_m"} <= set(rows[0])
    hand = tmp_path / "h.npz"
    assert main(["simulate", "--seconds", "2", "--rate", "250", "-o", str(hand)]) == 0
    assert main(["map", str(hand), "-o", str(out)]) == 1
    assert "not a walked survey" in capsys.readouterr().err
    assert main(["map", str(hand), "-o", str(tmp_path / "new")]) == 1
    assert not (tmp_path / "new").exists()      # a refused map makes no folder
    # a recording stopped before its first line was marked: said in one line (was a numpy traceback)
    import numpy as np
    with np.load(cap) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["line_marks"] = arrays["line_marks"][:0]
    np.savez(tmp_path / "unmarked.npz", **arrays)
    assert main(["map", str(tmp_path / "unmarked.npz"), "-o", str(tmp_path / "none")]) == 1
    assert "no line was marked start and end" in capsys.readouterr().err
