"""The simulated survey: the walk keeps to its grid, the site's field is what its sources say."""

import json

import numpy as np

from desktop.cli import main
from desktop.formats.capture import load_capture
from desktop.sim.field import earth_vector
from desktop.sim.scenario import Scenario, simulate
from desktop.sim.site import make_site
from desktop.sim.walk import MARK_JITTER_S, make_walk


def test_walk_keeps_to_the_grid():
    walk = make_walk(np.random.default_rng(1), width_m=4, length_m=5, spacing_m=1.0, zigzag=True)
    assert len(walk.line_marks) == 4
    t = np.arange(0, walk.seconds, 0.01)
    pos = walk.position(t)
    # the sensor 0.3 m above ground, bobbing 2 cm with the steps
    assert np.all(np.abs(pos[:, 2] + 0.3) <= 0.02 + 1e-9)
    for i, (t0, t1) in enumerate(walk.line_marks):
        at = walk.position(np.array([t0, t1]))
        start, end = (0.0, 5.0) if i % 2 == 0 else (5.0, 0.0)
        # a press is +-30 ms off (4 sigma), the walker 1 m/s +- a few %
        tol = 4 * MARK_JITTER_S * 1.1
        assert abs(at[0, 0] - start) < tol and abs(at[1, 0] - end) < tol
        # a late press is in the turn: r (1 - cos phi) at phi = pi (0.12 s / 2.5 s), r = 0.5 m
        assert np.allclose(at[:, 1], walk.line_y[i], atol=0.5 * (1 - np.cos(np.pi * 0.12 / 2.5)) + 1e-6)
    # tilt from vertical: roll within 10 deg wobble + the gait's 3 deg, pitch within 10 deg
    q = walk.orientation(t)
    w, x, y, z = q.T
    down = 1 - 2 * (x * x + y * y)          # world z of the sensor's z axis
    assert np.degrees(np.arccos(np.clip(down, -1, 1))).max() < np.hypot(10 + 3, 10) * 1.01


def test_parallel_lines_all_run_north():
    walk = make_walk(np.random.default_rng(3), width_m=3, length_m=4, spacing_m=1.0, zigzag=False)
    for t0, t1 in walk.line_marks:
        at = walk.position(np.array([t0, t1]))
        tol = 4 * MARK_JITTER_S * 1.1          # a press +-30 ms (4 sigma) at about 1 m/s
        assert abs(at[0, 0]) < tol and abs(at[1, 0] - 4.0) < tol
    # walking back between lines takes time: at 1.5 m/s the 4 m back, two 1.5 s turns
    gaps = walk.line_marks[1:, 0] - walk.line_marks[:-1, 1]
    assert np.all(gaps > 4.0 / 1.5 + 3.0 - 4 * MARK_JITTER_S)


def test_site_field_along_the_walk_is_its_sources():
    sc = Scenario(motion="survey", ideal=True, noise=0.0, adc_noise=False, rate=250, motion_seed=2,
                  survey=dict(width_m=10, length_m=10, spacing_m=1.0, site_seed=4))
    cap = simulate(sc, truth=True)
    site = sc.site()
    assert len(site.dipoles) >= 3 and site.pipe is not None
    pos, t = cap["position"], cap["t"]
    f = earth_vector(1.0, sc.inclination_deg, sc.declination_deg)
    expected = (site.objects_field(pos) @ f + site.clutter(pos[:, :2]) + site.diurnal(t))
    seen = cap["magnitude_true"] - sc.field_nT
    # |F + dB| - |F| = dB.F^ + |dB_perp|^2 / 2F: below 0.5 nT for anomalies under 6000 nT;
    # the sources are interpolated over 2.5 ms (far below that)
    big = np.abs(site.objects_field(pos)).max()
    assert np.abs(seen - expected).max() < max(0.05, big ** 2 / (2 * sc.field_nT) * 1.1)
    # the ideal sensor's |B| follows the truth to its quantisation (well below 0.1 nT)
    raw = np.linalg.norm(cap["codes"][:, :3] * cap["nT_per_code"], axis=1)
    assert np.median(np.abs(raw - cap["magnitude_true"])) < 0.1


def test_clutter_peak_to_peak_is_as_asked():
    site = make_site(20, 20, seed=5, clutter_ptp=3.0)
    g = np.linspace(0, 20, 161)
    xs, ys = np.meshgrid(g, g)
    c = site.clutter(np.c_[xs.ravel(), ys.ravel()])
    # scaled on an 81 x 81 sampling: a finer one finds at most a little more (1-6 m waves)
    assert 3.0 <= np.ptp(c) < 3.0 * 1.05


def test_cli_writes_marks_and_truth(tmp_path, capsys):
    out, truth = tmp_path / "s.npz", tmp_path / "t.json"
    assert main(["simulate", "--motion", "survey", "--grid", "4x4", "--line-spacing", "1", "--zigzag",
                 "--truth", str(truth), "-o", str(out)]) == 0
    cap = load_capture(str(out))
    assert cap["line_marks"].shape == (4, 2) and cap["config"]["survey"]["zigzag"] is True
    assert "position" in cap
    doc = json.loads(truth.read_text())
    assert [line["northward"] for line in doc["lines"]] == [True, False, True, False]
    assert main(["simulate", "--motion", "survey", "--grid", "4by4", "-o", str(out)]) == 1
    assert "--grid must be" in capsys.readouterr().err
