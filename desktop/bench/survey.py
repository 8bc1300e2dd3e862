"""What calibration buys in a walked survey's map: `python -m desktop.bench.survey`.

The same simulated site walked the same way (one walk, one site) with three sensors:

- the fluxgate uncalibrated (its nominal front-end scale: axes, gains and offsets as built),
- the same fluxgate and recording with fluxcal's calibration, fitted first on a hand
  rotation of that sensor (`fluxcal fit` on `fluxcal simulate --motion hand`),
- an ideal sensor (no errors: its |B| is what a scalar sensor reads).

Each survey goes through `fluxcal map`'s processing (desktop.survey.mapping). The table:

- stripes: rms of the traverse medians with destriping off (after the drift step), nT;
- found: buried objects whose peak exceeds 5 x the soil clutter (peak-to-peak) with a
  detection within 0.25 m of the source (the pipe: of its axis); missed: the others;
- invented: detections with no buried object (or the pipe's axis) within 1 m;
- position error: median and largest distance of the found objects' detections, m.

Then `fluxcal map` itself is timed on the calibrated survey (a subprocess: start-up, reading,
processing, the three files): its wall time and its CPU time (user + system, which a loaded
machine does not inflate) beside the machine's load.

    python -m desktop.bench.survey [--grid 20x20 --line-spacing 0.5 --sensor-seed 0 --site 0]
"""

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

from desktop.formats.calibration import save_calibration
from desktop.formats.capture import field_nT, save_capture
from desktop.methods import fit_array
from desktop.sim.scenario import Scenario, simulate
from desktop.survey.mapping import make_map

FOUND_M = 0.25          # the target: found within 0.25 m of the true position
INVENTED_M = 1.0        # a detection farther than this from every source is invented
RATIO = 5.0             # objects whose peak exceeds 5 x clutter must be found


def _pipe_distance(pipe, n, e):
    a = np.radians(pipe["azimuth_deg"])
    return abs((n - pipe["x"]) * np.sin(a) - (e - pipe["y"]) * np.cos(a))


def score(anomalies, site):
    """(found, missed, invented, errors m) of anomalies against the site's truth (Site.to_dict())."""
    truth = site["dipoles"] + ([site["pipe"]] if site["pipe"] else [])
    need = [o for o in truth if o["peak_nT"] > RATIO * site["clutter_ptp_nT"]]
    errors, missed = [], 0
    for o in need:
        if o["kind"] == "pipe":
            d = [_pipe_distance(o, a.north_m, a.east_m) for a in anomalies if a.kind == "linear"]
        else:
            d = [np.hypot(a.north_m - o["x"], a.east_m - o["y"]) for a in anomalies]
        if d and min(d) <= FOUND_M:
            errors.append(min(d))
        else:
            missed += 1
    invented = 0
    for a in anomalies:
        near = [np.hypot(a.north_m - o["x"], a.east_m - o["y"]) for o in site["dipoles"]]
        if site["pipe"]:
            near.append(_pipe_distance(site["pipe"], a.north_m, a.east_m))
        invented += not near or min(near) > INVENTED_M
    return len(errors), missed, invented, errors


def run(grid, spacing, sensor, sensor_seed, site_seed, motion_seed, out_dir, pipe=True):
    width, length = (float(v) for v in grid.split("x"))
    survey = dict(width_m=width, length_m=length, spacing_m=spacing, zigzag=True, site_seed=site_seed, pipe=pipe)
    common = dict(motion="survey", rate=250, motion_seed=motion_seed, survey=survey)
    hand = simulate(Scenario(sensor=sensor, seed=sensor_seed, motion="hand", seconds=60.0, rate=250,
                             motion_seed=motion_seed + 100), truth=False)
    cal = fit_array(field_nT(hand))
    cal_path = os.path.join(out_dir, "cal.json")
    save_calibration(cal_path, cal)
    walked = Scenario(sensor=sensor, seed=sensor_seed, **common)
    paths = {}
    for name, sc in (("fluxgate", walked), ("ideal", Scenario(sensor=sensor, ideal=True, **common))):
        paths[name] = os.path.join(out_dir, name + ".npz")
        save_capture(paths[name], simulate(sc, truth=False))
    site = walked.site().to_dict()
    rows = []
    for label, path, c in (("uncalibrated %s" % sensor, paths["fluxgate"], None),
                           ("calibrated %s (fluxcal)" % sensor, paths["fluxgate"], cal),
                           ("ideal sensor", paths["ideal"], None)):
        res = make_map(path, c)
        found, missed, invented, errors = score(res.anomalies, site)
        rows.append((label, res.stripes_nT, found, missed, invented, errors, res.threshold_nT))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "desktop", "map", paths["fluxgate"], "--cal", cal_path,
                    "-o", os.path.join(out_dir, "map")], check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return rows, site, (wall, cpu), walked.seconds


def print_table(rows, need, first="sensor"):
    """The markdown table of rows (label, stripes, found, missed, invented, errors, level)."""
    print("| %s | stripes, nT rms | found (of %d) | missed | invented | position error, m (median / max) "
          "| detection level, nT |" % (first, need))
    print("|---|---|---|---|---|---|---|")
    for label, stripes, found, missed, invented, errors, level in rows:
        err = "%.2f / %.2f" % (np.median(errors), max(errors)) if errors else "-"
        print("| %s | %.2f | %d | %d | %d | %s | %.1f |" % (label, stripes, found, missed, invented, err, level))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grid", default="20x20")
    p.add_argument("--line-spacing", type=float, default=0.5)
    p.add_argument("--sensor", default="mag649")
    p.add_argument("--sensor-seed", type=int, default=0)
    p.add_argument("--site", type=int, default=0)
    p.add_argument("--motion-seed", type=int, default=1)
    p.add_argument("--no-pipe", action="store_true", help="a site without the pipe")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        rows, site, wall, seconds = run(args.grid, args.line_spacing, args.sensor, args.sensor_seed, args.site,
                                        args.motion_seed, tmp, not args.no_pipe)
    need = [o for o in site["dipoles"] + ([site["pipe"]] if site["pipe"] else [])
            if o["peak_nT"] > RATIO * site["clutter_ptp_nT"]]
    print("site %d: %s m, lines %g m apart (zig-zag), %.0f s walked; %d buried objects and %s, clutter %.1f nT PTP; "
          "%d peak over %.0f nT (5 x clutter)" % (args.site, args.grid, args.line_spacing, seconds,
                                                  len(site["dipoles"]), "a pipe" if site["pipe"] else "no pipe",
                                                  site["clutter_ptp_nT"], len(need),
                                                  RATIO * site["clutter_ptp_nT"]))
    print()
    print_table(rows, len(need))
    print()
    print("fluxcal map on the calibrated survey (%s m, %g m lines): %.1f s wall, %.1f s CPU (%d CPUs, load %.1f)"
          % (args.grid, args.line_spacing, wall[0], wall[1], os.cpu_count(), os.getloadavg()[0]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
