"""fluxcal tempco CAL.json CAL.json [...] -o OUT.json: temperature coefficients from calibrations.

Two or more calibrations of one sensor at one site, at temperatures 2 C or more apart
(each record's meta.temperature_c: the handheld's pull-cal, or `fluxcal fit` of a
capture), give the offsets' and the raw axes' gains' coefficients (shared/tempco.py,
docs/temperature.md). They are attached to the last calibration given (its matrix and
offset are for its own temperature), in nT (pull-cal's code-unit files are converted),
which push-cal then sends to the handheld (converted back with its scale): the survey's
|B| is compensated at the die temperature over the range they were measured.
"""

from desktop.cli._errors import CommandError

HELP = "fit temperature coefficients from calibrations at different temperatures"


def add_arguments(p):
    p.add_argument("calibrations", metavar="CAL.json", nargs="+",
                   help="two or more calibrations with meta.temperature_c; the last one gets the coefficients")
    p.add_argument("-o", "--output", required=True, help="the last calibration with its coefficients (JSON)")


def run(args):
    from desktop.formats.calibration import load_calibration, save_calibration, takes_codes, to_nT_units
    from shared.tempco import attach, fit_tempco

    if len(args.calibrations) < 2:
        raise CommandError("temperature coefficients need two or more calibrations, got %d" % len(args.calibrations))
    cals = []
    for path in args.calibrations:
        cal = load_calibration(path)
        if cal.meta.get("temperature_c") is None:
            raise CommandError("%s has no meta.temperature_c: pull it from the handheld or fit a capture" % path)
        if takes_codes(cal):   # the handheld's (pull-cal): in nT, like fit's, so they all share one unit
            if cal.meta.get("scale") is None:
                raise CommandError("%s takes ADC codes and has no meta.scale (nT per code) to convert it" % path)
            cal = to_nT_units(cal, cal.meta["scale"])
        cals.append(cal)
    try:
        out = attach(cals[-1], fit_tempco(cals))
    except ValueError as exc:
        raise CommandError("no coefficients: %s" % exc)
    save_calibration(args.output, out)
    tc = out.tempco
    print("%d calibrations over %.1f..%.1f C; reference %.2f C" % (len(cals), tc["range_c"][0], tc["range_c"][1], tc["t0_c"]))
    print("offsets %s nT/C; gains %s ppm/C" % (" ".join("%+.4g" % v for v in tc["offset_per_c"]),
                                               " ".join("%+.3f" % (v * 1e6) for v in tc["gain_per_c"])))
    return 0
