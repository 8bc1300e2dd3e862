"""fluxcal map SURVEY.npz -o DIR [--cal CAL.json] [--no-despike --no-drift --no-destripe --no-interpolate]

Input: a walked survey's capture as `fluxcal simulate --motion survey` writes it (the
raw codes, their times, the markers at each line's start and end, the grid in its
config); --cal applies a calibration (`fluxcal fit`'s JSON, or a device's in codes)
to every reading before |B| is taken. Writes DIR/map.png, DIR/grid.csv and
DIR/anomalies.csv, and prints what each processing step did and one line per anomaly.
"""

import os

from desktop.cli._errors import CommandError

HELP = "map a walked survey: positions from markers and pace, destripe, despike, drift, grid, anomalies"


def add_arguments(p):
    p.add_argument("survey", help="survey capture .npz (fluxcal simulate --motion survey)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="directory for map.png, grid.csv, anomalies.csv")
    p.add_argument("--cal", metavar="CAL.json", help="calibration to apply to every reading (fluxcal fit)")
    p.add_argument("--clip", type=float, default=10.0, metavar="NT", help="map greyscale clip, +-nT (default 10)")
    p.add_argument("--sample", type=float, default=0.125, metavar="M",
                   help="along-line sample interval, m (default 0.125: 8 per metre)")
    p.add_argument("--threshold", type=float, default=None, metavar="NT",
                   help="anomaly detection level, nT (default 6 robust sigmas of the map, 1 nT or more)")
    for step, what in (("despike", "single-sample spikes"), ("drift", "the field's slow drift"),
                       ("destripe", "each traverse's median (zero-median traverse)"),
                       ("interpolate", "linear interpolation across the lines")):
        p.add_argument("--no-" + step, action="store_true", help="do not remove %s" % what
                       if step != "interpolate" else "no %s (one column per traverse)" % what)


def run(args):
    from desktop.formats.calibration import load_calibration
    from desktop.survey.gridding import write_xyz
    from desktop.survey.mapping import make_map
    from desktop.survey.outputs import write_anomalies, write_map
    from desktop.survey.processing import STEPS

    if args.clip <= 0 or not 0.01 <= args.sample <= 1.0:
        raise CommandError("--clip must be positive and --sample within 0.01..1 m")
    cal = load_calibration(args.cal) if args.cal else None
    steps = [s for s in STEPS if not getattr(args, "no_" + s)]
    res = make_map(args.survey, cal, steps, not args.no_interpolate, args.sample, args.threshold)
    if not os.path.isdir(args.output):     # only once the map is made: a refused survey leaves no folder
        try:
            os.makedirs(args.output)
        except OSError as exc:
            raise CommandError("%s: %s" % (args.output, exc.strerror or exc))
    on_handheld = res.survey_grid.handheld_calibrated
    what = "total-field anomaly of %s, %s" % (os.path.basename(args.survey),
                                              "calibrated by %s" % os.path.basename(args.cal) if cal
                                              else "calibrated on the handheld" if on_handheld else "uncalibrated")
    write_xyz(os.path.join(args.output, "grid.csv"), res.grid, what + "; steps: " + (", ".join(steps) or "none"))
    write_anomalies(os.path.join(args.output, "anomalies.csv"), res.anomalies)
    write_map(os.path.join(args.output, "map.png"), res.grid, args.clip, what, res.anomalies)
    g = res.survey_grid
    print("%s: %g m x %g m, %d traverses %g m apart (%s), %s" % (
        args.survey, g.width_m, g.length_m, len(res.lines), g.spacing_m, "zig-zag" if g.zigzag else "parallel",
        what.split(", ", 1)[1]))
    for line in res.report:
        print("  " + line)
    print("  stripes before destriping: %.2f nT rms of the traverse medians" % res.stripes_nT)
    print("%d anomalies over %.1f nT%s" % (len(res.anomalies), res.threshold_nT, ":" if res.anomalies else ""))
    for k, a in enumerate(res.anomalies, 1):
        print("  %d. %s" % (k, a.summary()))
    print("wrote %s (map.png, grid.csv, anomalies.csv)" % args.output)
    return 0
