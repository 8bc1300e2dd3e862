"""`fluxcal simulate`: a virtual hand calibration (or spin, ...) written as a capture file."""

import os

from desktop.cli._errors import CommandError

HELP = "simulate a capture: fluxgate, operator motion and two ADS1292 (writes .npz, optional CSV)"


def add_arguments(p):
    from desktop.sim.field import DECLINATION_DEG, EARTH_NT, INCLINATION_DEG
    from desktop.sim.motion import MOTIONS
    from desktop.sim.scenario import RATES
    from desktop.sim.sensor import PRESETS
    p.add_argument("-o", "--output", required=True, metavar="CAPTURE.npz", help="capture file to write")
    p.add_argument("--sensor", default="mag649", choices=sorted(PRESETS),
                   help="sensor preset (Mag649: 1 kHz bandwidth, Mag648: 5 Hz; paper: a Mag649 with the paper's "
                        "uncalibrated errors, Table 2's 24,055 nT PTP)")
    p.add_argument("--motion", default="hand", choices=MOTIONS + ("survey",),
                   help="operator motion (survey: a walked grid over a site of buried iron, see --grid)")
    p.add_argument("--seconds", type=float, default=120.0, help="capture length, s (default 120)")
    p.add_argument("--rate", type=int, default=None,
                   help="ADS1292 data rate, SPS: one of %s (default 4000, the nearest to the paper's 3 kHz; "
                        "250 for a survey)" % ", ".join(map(str, RATES)))
    p.add_argument("--noise", type=float, default=0.1, help="sensor white noise, nT rms per conversion")
    p.add_argument("--pink", type=float, default=0.0, help="sensor 1/f noise, nT rms (default off)")
    p.add_argument("--coverage", type=float, default=1.0,
                   help="fraction of the sphere the motion may reach (hand, cap), 0..1")
    p.add_argument("--rot-rate", type=float, default=1.0, help="typical rotation rate, rev/s")
    p.add_argument("--seed", type=int, default=0, help="fixes the sensor (its errors), not the motion")
    p.add_argument("--motion-seed", type=int, default=1, help="varies the motion (and noise realisation)")
    p.add_argument("--bandwidth", type=float, default=None, help="override the sensor bandwidth, Hz")
    p.add_argument("--poles", type=int, choices=(1, 2), default=1,
                   help="the sensor's response: 1 first order (default), 2 two equal poles, same -3 dB bandwidth")
    p.add_argument("--bandwidth-spread", type=float, default=0.0, metavar="SHARE",
                   help="each axis' bandwidth drawn within +- this share of it (e.g. 0.03; default 0)")
    p.add_argument("--field", type=float, default=EARTH_NT, help="local field magnitude, nT (default %(default).0f)")
    p.add_argument("--inclination", type=float, default=INCLINATION_DEG, help="field inclination, degrees")
    p.add_argument("--declination", type=float, default=DECLINATION_DEG, help="field declination, degrees")
    p.add_argument("--drift", type=float, default=0.0, help="field drift, nT/min")
    p.add_argument("--gradient", type=float, default=0.0, help="field gradient, nT/m")
    p.add_argument("--dipole", type=float, default=None, metavar="M",
                   help="a vehicle (300 A m^2) passes at this distance (m), mid-capture, 10 m/s")
    p.add_argument("--temp", type=float, default=25.0, help="temperature at the start, C (default 25)")
    p.add_argument("--temp-drift", type=float, default=0.0, help="temperature drift, C/min")
    p.add_argument("--gain", type=int, default=1, help="ADS1292 PGA gain (1, 2, 3, 4, 6, 8, 12)")
    p.add_argument("--ideal", action="store_true", help="a perfect sensor and front end")
    p.add_argument("--no-adc-noise", action="store_true", help="switch off the ADS1292's own noise")
    p.add_argument("--truth", nargs="?", const=True, default=False, metavar="FILE",
                   help="also store the true field, orientation, position and temperature of every conversion; "
                        "a survey also writes its buried objects and walked lines to FILE (JSON)")
    g = p.add_argument_group("survey (--motion survey)")
    g.add_argument("--grid", default="20x20", metavar="WxL",
                   help="grid width (east, across the lines) x length (north, along them), m (default 20x20)")
    g.add_argument("--line-spacing", type=float, default=0.5, metavar="M", help="traverse spacing, m (default 0.5)")
    g.add_argument("--zigzag", action="store_true", help="walk every other line back (default: all lines north)")
    g.add_argument("--speed", type=float, default=1.0, help="walking pace, m/s (default 1)")
    g.add_argument("--site", type=int, default=0, metavar="SEED", help="the site's buried objects and soil (default 0)")
    g.add_argument("--clutter", type=float, default=2.0, help="soil clutter, nT peak-to-peak (default 2)")
    g.add_argument("--diurnal", type=float, default=20.0, help="the day's field variation, nT amplitude (default 20)")
    g.add_argument("--no-pipe", action="store_true", help="a site without the buried pipe")
    p.add_argument("--csv", metavar="PATH", help="also write x,y,z (nT) and extras as CSV")
    p.add_argument("--csv-every", type=int, default=1, metavar="K", help="CSV: every K-th row")


def scenario_from_args(args):
    """A Scenario from parsed arguments; CommandError on bad values."""
    from desktop.sim.scenario import Scenario
    dipole = None
    if args.dipole is not None:
        if args.dipole <= 0:
            raise CommandError("--dipole must be a positive distance in m")
        dipole = {"distance_m": args.dipole, "t_closest_s": args.seconds / 2}
    survey = _survey_settings(args) if args.motion == "survey" else None
    rate = args.rate if args.rate is not None else (250 if survey else 4000)
    kw = dict(sensor=args.sensor, motion=args.motion, seconds=args.seconds, rate=rate, survey=survey,
              noise=args.noise, pink=args.pink, coverage=args.coverage, rot_rate=args.rot_rate,
              seed=args.seed, motion_seed=args.motion_seed, field_nT=args.field,
              inclination_deg=args.inclination, declination_deg=args.declination,
              drift=args.drift, gradient=args.gradient, dipole=dipole,
              temp_c=args.temp, temp_drift=args.temp_drift, gain=args.gain, ideal=args.ideal,
              adc_noise=not args.no_adc_noise, poles=args.poles, bandwidth_spread=args.bandwidth_spread)
    if args.bandwidth is not None:
        if args.bandwidth <= 0:
            raise CommandError("--bandwidth must be positive (Hz)")
        kw["bandwidth"] = args.bandwidth
    if not 0 <= args.bandwidth_spread < 0.5:
        raise CommandError("--bandwidth-spread must be in [0, 0.5)")
    for name in ("noise", "pink", "rot_rate"):
        if kw[name] < 0:
            raise CommandError("--%s must not be negative" % name.replace("_", "-"))
    if not 0 < args.seconds <= 3600:
        raise CommandError("--seconds must be in (0, 3600]")
    if isinstance(args.truth, str) and args.motion != "survey":
        raise CommandError("--truth FILE is for --motion survey; give --truth alone for the capture's truth")
    try:
        return Scenario(**kw)
    except ValueError as exc:
        raise CommandError(str(exc))


def _survey_settings(args):
    from desktop.cli._survey_grid import parse_grid
    width, length = parse_grid(args.grid, args.line_spacing)
    if not 0.2 <= args.speed <= 3:
        raise CommandError("--speed must be within 0.2..3 m/s")
    if not 0 <= args.clutter <= 100 or args.diurnal < 0:
        raise CommandError("--clutter must be within 0..100 nT and --diurnal not negative")
    return dict(width_m=width, length_m=length, spacing_m=args.line_spacing, zigzag=args.zigzag,
                speed=args.speed, site_seed=args.site, clutter_ptp=args.clutter, diurnal_nT=args.diurnal,
                pipe=not args.no_pipe)


def write_truth(path, sc, cap):
    """The survey's truth as JSON: the site's objects (with their peak anomaly) and the walked lines."""
    import json
    walk = sc.walk()
    pos = cap.get("position")
    lines = []
    for i, (t0, t1) in enumerate(walk.line_marks):
        line = {"index": i, "east_m": float(walk.line_y[i]), "marks_s": [float(t0), float(t1)],
                "northward": bool(not walk.zigzag or i % 2 == 0)}
        lines.append(line)
    out = {"site": sc.site().to_dict(), "lines": lines, "sensor_height_m": 0.3,
           "positions": "the capture's position key (x north, y east, z down, m) at every conversion"
           if pos is not None else None}
    try:
        with open(path, "w") as fh:
            json.dump(out, fh, indent=1)
            fh.write("\n")
    except OSError as exc:
        raise CommandError("%s: %s" % (path, exc.strerror or exc))


def run(args):
    import numpy as np

    from desktop.formats.capture import field_nT, save_capture, write_csv
    from desktop.sim.scenario import simulate

    sc = scenario_from_args(args)
    out_dir = os.path.dirname(os.path.abspath(args.output))
    if not os.path.isdir(out_dir):
        raise CommandError("%s: directory does not exist" % out_dir)
    cap = simulate(sc, truth=bool(args.truth))
    save_capture(args.output, cap)
    if isinstance(args.truth, str):
        write_truth(args.truth, sc, cap)
    if args.csv:
        write_csv(args.csv, cap, max(args.csv_every, 1))
    mag = np.linalg.norm(field_nT(cap), axis=1)
    clipped = int((np.abs(cap["codes"][:, :3]) >= (1 << 23) - 1).sum())
    walked = ""
    if sc.motion == "survey":
        site = sc.site()
        walked = " (%d lines, %d objects%s)" % (len(cap["line_marks"]), len(site.dipoles),
                                                " and a pipe" if site.pipe else "")
    print("wrote %s: %d frames at %d SPS (%.1f s), %s, %s motion%s; raw |B| %.0f..%.0f nT%s"
          % (args.output, len(cap["t"]), sc.rate, sc.seconds, sc.sensor, sc.motion, walked,
             mag.min(), mag.max(), ", %d clipped codes" % clipped if clipped else ""))
    return 0
