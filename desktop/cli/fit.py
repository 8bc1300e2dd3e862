"""fluxcal fit RAW -o CAL.json"""

from desktop.cli import CommandError
from desktop.methods import METHODS

HELP = "fit a calibration to raw readings (CSV x,y,z in nT, or a capture .npz)"


def add_arguments(p):
    p.add_argument("raw", help="CSV with a header containing x,y,z (nT), or a simulator .npz")
    p.add_argument("-o", "--output", required=True, help="calibration JSON to write")
    p.add_argument("--method", choices=METHODS, default="streaming",
                   help="streaming (the device's own fit, default), algebraic, mle or paper-nn")
    p.add_argument("--field", type=float, default=None, help="known local field magnitude, nT")
    p.add_argument("--float32", action="store_true", help="run the streaming solve in 32-bit floats, as most boards do")


def run(args):
    from desktop.formats.calibration import save_calibration
    from desktop.formats.readings import read_raw
    from desktop.methods import fit_array
    from shared.fit import FitError

    if args.field is not None and not args.field > 0:
        raise CommandError("--field must be a positive number of nT")
    if args.float32 and args.method != "streaming":
        raise CommandError("--float32 applies to the streaming method only")
    h = read_raw(args.raw)
    try:
        cal = fit_array(h, args.method, field=args.field, float32=args.float32)
    except FitError as exc:
        raise CommandError("calibration failed (%s): %s" % (exc.reason, exc.message))
    except (ValueError, ArithmeticError) as exc:
        raise CommandError("calibration failed (%s): %s" % (args.method, exc))
    cal.meta["method"] = args.method
    cal.meta["source"] = args.raw
    save_calibration(args.output, cal)
    d = cal.diagnostics
    print("%s: %d samples, field %.2f nT, residual rms %.3f nT" % (args.method, d.get("n", len(h)), cal.field, d.get("rms", float("nan"))))
    if "predicted_error" in d:
        print("predicted full-sphere calibration error %.3f nT, observability %.3f" % (d["predicted_error"], d["observability"]))
    return 0
