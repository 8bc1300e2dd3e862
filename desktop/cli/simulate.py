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
    p.add_argument("--motion", default="hand", choices=MOTIONS, help="operator motion")
    p.add_argument("--seconds", type=float, default=120.0, help="capture length, s (default 120)")
    p.add_argument("--rate", type=int, default=4000,
                   help="ADS1292 data rate, SPS: one of %s (default 4000, the nearest to the paper's 3 kHz)"
                   % ", ".join(map(str, RATES)))
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
    p.add_argument("--truth", action="store_true",
                   help="also store the true field, orientation, position and temperature of every conversion")
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
    kw = dict(sensor=args.sensor, motion=args.motion, seconds=args.seconds, rate=args.rate,
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
    try:
        return Scenario(**kw)
    except ValueError as exc:
        raise CommandError(str(exc))


def run(args):
    import numpy as np

    from desktop.formats.capture import field_nT, save_capture, write_csv
    from desktop.sim.scenario import simulate

    sc = scenario_from_args(args)
    out_dir = os.path.dirname(os.path.abspath(args.output))
    if not os.path.isdir(out_dir):
        raise CommandError("%s: directory does not exist" % out_dir)
    cap = simulate(sc, truth=args.truth)
    save_capture(args.output, cap)
    if args.csv:
        write_csv(args.csv, cap, max(args.csv_every, 1))
    mag = np.linalg.norm(field_nT(cap), axis=1)
    clipped = int((np.abs(cap["codes"][:, :3]) >= (1 << 23) - 1).sum())
    print("wrote %s: %d frames at %d SPS (%.1f s), %s, %s motion; raw |B| %.0f..%.0f nT%s"
          % (args.output, len(cap["t"]), sc.rate, sc.seconds, sc.sensor, sc.motion,
             mag.min(), mag.max(), ", %d clipped codes" % clipped if clipped else ""))
    return 0
