"""A walked survey through the firmware: `python -m desktop.bench.survey_firmware`.

The site and walk of desktop/sim/ (site.py, walk.py) on the byte-level handheld: the
firmware in this process on the two emulated ADS1292 (desktop/devicesim/), simulated time
as fast as it runs (not paced to the wall clock), a surveyor (desktop/devicesim/walker.py)
walking the grid and pressing the button at the start and end of every line. What the
firmware streams (its |B| blocks and `mark` events, as `fluxcal survey` records them) is
made into the same file (desktop/survey/recording.py) and mapped as `fluxcal map` maps it,
twice: the handheld uncalibrated, and with fluxcal's calibration in force (fitted on a 60 s
hand rotation of the same sensor and sent with `set-cal`, as `fluxcal push-cal` does). The
same site walked by the vectorised simulator (`python -m desktop.bench.survey`'s rows, every
conversion mapped) is printed beside it.

    python -m desktop.bench.survey_firmware [--grid 10x10 --line-spacing 1 --site 0 --pipe]
    python -m desktop.bench.survey_firmware --sensor mag648

With `--sensor mag648` (the paper's 5 Hz fluxgate) the calibration is fitted as
`fluxcal fit --lag auto` fits it (its lag estimated and undone on 120 s of hand rotation at
0.5 rev/s, 1000 samples/s) and sent with its response, which the firmware's survey output
then de-lags with; a third walk sends the same calibration without its response (the survey
output not de-lagged), and of the simulator only the ideal sensor is printed (its fitted rows
take no lag into account).
"""

import argparse
import json
import os
import sys
import tempfile

import numpy as np

from desktop.bench.survey import RATIO, print_table, run as run_vectorised, score
from desktop.devicesim.procedure import handheld_config
from desktop.devicesim.runners import start_device, write_config
from desktop.devicesim.walker import Walker
from desktop.devicesim.world import BATCH, World
from desktop.formats.calibration import to_code_units
from desktop.formats.capture import field_nT
from desktop.methods import fit_array
from desktop.methods.lag import delag, estimate_response
from desktop.sim.handheld import Handheld
from desktop.sim.scenario import Scenario, simulate
from desktop.survey.mapping import make_map
from desktop.survey.recording import Recording
from shared.calibration import Calibration


def _say(w, dev, line, dt=0.3):
    start = len(w.lines())
    w.send(line.encode() + b"\n")
    dev.run_until(w.time + dt)
    replies = [json.loads(x) for x in w.lines()[start:] if '"ok"' in x]
    if not replies or not replies[-1]["ok"]:
        raise RuntimeError("the firmware refused %r: %s" % (line[:40], replies[-1:]))
    return replies[-1]


def walk_firmware(sc, cal, root, path):
    """Walk `sc` (motion "survey") on the firmware, `cal` (nT units, or None) in force; the
    recording written to `path`; its (readings, marks)."""
    walker = Walker(sc.walk())
    hh = Handheld(sc, operator=walker, batch=BATCH)
    w = World(hh, serial=None)
    config = handheld_config(sc)
    write_config(root, **config)
    dev = start_device(w, root, kind="cpython")
    try:
        dev.run_until(0.5)
        if cal is not None:
            k = [config["scale_" + a] for a in "xyz"]
            _say(w, dev, "set-cal " + json.dumps(to_code_units(cal, k).to_dict()))
        _say(w, dev, "stream corrected")
        t0 = _say(w, dev, "survey start")["t0"]
        since = len(w.lines())
        for down, up in walker.begin(w.time - hh.t0):
            w.press(up - down, at=hh.t0 + down)
        dev.run_until(hh.t0 + walker.start + walker.walk.seconds + 0.5)
        lines = [json.loads(x) for x in w.lines()[since:]]
    finally:
        dev.close()
    s = sc.survey
    rec = Recording(dict(width_m=s["width_m"], length_m=s["length_m"], spacing_m=s["spacing_m"], zigzag=s["zigzag"],
                         pace_s_per_m=1.0 / s["speed"]), [config["scale_" + a] for a in "xyz"],
                    {"handheld_calibrated": cal is not None, "source_detail": "desktop.bench.survey_firmware"})
    for ev in lines:
        if ev.get("ev") == "data" and ev["t"] > t0:
            rec.reading(ev["t"] - t0, ev["f"], ev["c"], ev["temp"])
        elif ev.get("ev") == "mark":
            rec.mark(ev["ms"])
    rec.save(path)
    return len(rec.readings), len(rec.marks)


def lag_aware_calibration(sensor, sensor_seed, motion_seed):
    """`fluxcal fit --lag auto` on 120 s of hand rotation at 0.5 rev/s, 1000 samples/s: the
    calibration (nT units) with its response."""
    rate = 1000
    hand = simulate(Scenario(sensor=sensor, seed=sensor_seed, motion="hand", seconds=120.0, rate=rate,
                             rot_rate=0.5, motion_seed=motion_seed + 100), truth=False)
    h = field_nT(hand)
    t = np.arange(len(h)) / float(rate)
    est = estimate_response(h, t)
    cal = fit_array(delag(h, t, est["tau_s"]))
    cal.response = {"model": "first-order", "tau_s": [float(v) for v in est["tau_s"]],
                    "tau_sigma_s": [float(v) for v in est["tau_sigma_s"]], "source": "estimated"}
    return cal


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grid", default="10x10")
    p.add_argument("--line-spacing", type=float, default=1.0)
    p.add_argument("--site", type=int, default=0)
    p.add_argument("--sensor", choices=("mag649", "mag648"), default="mag649")
    p.add_argument("--sensor-seed", type=int, default=0)
    p.add_argument("--motion-seed", type=int, default=1)
    p.add_argument("--pipe", action="store_true", help="a site with the pipe (on 10 m it stripes the ideal map)")
    args = p.parse_args(argv)
    width, length = (float(v) for v in args.grid.split("x"))
    survey = dict(width_m=width, length_m=length, spacing_m=args.line_spacing, zigzag=True, site_seed=args.site,
                  pipe=args.pipe)
    sc = Scenario(sensor=args.sensor, seed=args.sensor_seed, motion_seed=args.motion_seed, motion="survey",
                  survey=survey, rate=1000)
    if args.sensor == "mag648":
        cal = lag_aware_calibration(args.sensor, args.sensor_seed, args.motion_seed)
        bare = Calibration.from_dict(dict(cal.to_dict(), response=None))
        walks = (("firmware, uncalibrated", None), ("firmware, calibrated (set-cal), survey de-lagged", cal),
                 ("firmware, calibrated (set-cal), survey not de-lagged", bare))
    else:
        # the calibration `python -m desktop.bench.survey` fits: 60 s of hand rotation of the same sensor
        hand = simulate(Scenario(sensor=args.sensor, seed=args.sensor_seed, motion="hand", seconds=60.0, rate=250,
                                 motion_seed=args.motion_seed + 100), truth=False)
        cal = fit_array(field_nT(hand))
        walks = (("firmware, uncalibrated", None), ("firmware, calibrated (set-cal)", cal))
    site = sc.site().to_dict()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, c in walks:
            path = os.path.join(tmp, "survey.npz")
            n, marks = walk_firmware(sc, c, os.path.join(tmp, "flash-%d" % len(rows)), path)
            res = make_map(path, sample_m=0.25)      # 10 blocks a second at 1 m/s: 0.25 m samples
            rows.append((label + ", %d blocks, %d marks" % (n, marks), res.stripes_nT) + score(res.anomalies, site)
                        + (res.threshold_nT,))
        vec, _site, _t, _seconds = run_vectorised(args.grid, args.line_spacing, args.sensor, args.sensor_seed,
                                                  args.site, args.motion_seed, tmp, args.pipe)
    rows += [("simulator, " + r[0],) + r[1:] for r in vec if args.sensor == "mag649" or r[0] == "ideal sensor"]
    need = [o for o in site["dipoles"] + ([site["pipe"]] if site["pipe"] else [])
            if o["peak_nT"] > RATIO * site["clutter_ptp_nT"]]
    print("site %d: %s m, lines %g m apart (zig-zag), %.0f s walked, %s; %d buried objects and %s; %d peak over %.0f nT"
          % (args.site, args.grid, args.line_spacing, sc.walk().seconds, args.sensor, len(site["dipoles"]),
             "a pipe" if site["pipe"] else "no pipe", len(need), RATIO * site["clutter_ptp_nT"]))
    print()
    print_table(rows, len(need), "survey")
    return 0


if __name__ == "__main__":
    sys.exit(main())
