"""fluxcal push-cal CAL.json: make a calibration file the handheld's calibration in force.

Checked here before anything is sent (a valid record, a positive definite
matrix, a field the Earth has), then by the firmware's own acceptance checks
(set-cal). A file from `fluxcal fit` takes nT; it is converted to the device's
code units with the device's front-end scale (config scale_x/y/z). The calibration
it replaces is written first, beside CAL.json (replaced-YYYYMMDD-HHMMSS.json, a
pull-cal file), so that the wrong file pushed is one push-cal from undone; none is
written when the same calibration is in force, and it is removed when the firmware
refuses the new one (the old one then stays in force).
"""

import json
import os
import time

from desktop.cli._errors import CommandError
from desktop.cli._device import add_port_arguments, connected, device_config, nT_per_code, save_device_calibration
from shared.codes import MAX_LINE

HELP = "send a calibration JSON to the handheld (validated here and by the firmware)"


def add_arguments(p):
    p.add_argument("calibration", metavar="CAL.json", help="from fluxcal pull-cal (codes) or fluxcal fit (nT)")
    add_port_arguments(p)


def run(args):
    from desktop.cli._show import fit_figures
    from desktop.formats.calibration import load_calibration, plausibility_problem, takes_codes, to_code_units

    cal = load_calibration(args.calibration)
    problem = plausibility_problem(cal)
    if problem:
        raise CommandError("%s: not sent: %s" % (args.calibration, problem))
    from desktop.link import DeviceError

    with connected(args) as dev:
        converted = not takes_codes(cal)
        scale = nT_per_code(device_config(dev))
        cal = to_code_units(cal, scale)
        request = "set-cal " + json.dumps(cal.to_dict(), separators=(",", ":"))
        if len(request) > MAX_LINE:   # the firmware would drop it (line_too_long)
            raise CommandError("%s: %d bytes as a request, the firmware takes %d: trim its meta"
                               % (args.calibration, len(request), MAX_LINE))
        old = dev.ask("get-cal")["cal"]
        kept = None if old is None or _same(old, cal, applied=True) else _keep(old, scale, args.calibration)
        try:
            dev.ask(request)
        except DeviceError:      # refused: the one in force stays, and no copy of it is left
            if kept:
                os.remove(kept)
            raise
        back = dev.ask("get-cal")["cal"]
    if back is None or not _same(back, cal):
        raise CommandError("the handheld accepted the calibration but reports another one back")
    print("pushed %s to %s%s: saved and in force" % (
        args.calibration, dev.port, " (converted from nT to its code units)" if converted else ""))
    print("  " + fit_figures(dict(cal.diagnostics, field=cal.field)))
    if cal.response is not None:
        print("  its survey output de-lagged with tau %s ms" % ", ".join("%.3f" % (1e3 * t) for t in cal.response["tau_s"]))
    if kept:
        print("  the calibration it replaced is in %s: fluxcal push-cal %s puts it back" % (kept, kept))
    return 0


def _keep(record, scale, pushed):
    """The calibration in force (get-cal's record) written beside the pushed file; its path."""
    from desktop.formats import FormatError

    stem = os.path.join(os.path.dirname(os.path.abspath(pushed)), "replaced-" + time.strftime("%Y%m%d-%H%M%S"))
    path, n = stem + ".json", 1
    while os.path.exists(path):    # two pushes within a second
        n += 1
        path = "%s-%d.json" % (stem, n)
    try:
        save_device_calibration(record, scale, path)
    except (CommandError, FormatError) as exc:
        raise CommandError("not sent: the calibration in force could not be kept first (%s)" % exc)
    return os.path.relpath(path)


def _same(record, cal, applied=False):
    """The record is `cal` to the precision of a board's float32: its matrix, offset and field (the
    one the device reports back); applied: its response and temperature coefficients too, all the
    survey applies (the one in force, which push-cal keeps only where it differs)."""
    mine = {"matrix": cal.matrix, "offset": cal.offset, "field": cal.field, "response": cal.response,
            "tempco": cal.tempco}
    return all(_near(record.get(k), mine[k]) for k in ("matrix", "offset", "field") + (("response", "tempco")
                                                                                        if applied else ()))


def _near(a, b, rel=1e-5):
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return abs(a - b) <= rel * max(abs(a), abs(b), 1e-12)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_near(a[k], b[k], rel) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_near(x, y, rel) for x, y in zip(a, b))
    return a == b
