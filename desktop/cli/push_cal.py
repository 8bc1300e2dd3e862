"""fluxcal push-cal CAL.json: make a calibration file the handheld's calibration in force.

Checked here before anything is sent (a valid record, a positive definite
matrix, a field the Earth has), then by the firmware's own acceptance checks
(set-cal). A file from `fluxcal fit` takes nT; it is converted to the device's
code units with the device's front-end scale (config scale_x/y/z).
"""

import json

from desktop.cli._errors import CommandError
from desktop.cli._device import add_port_arguments, connected, device_config, nT_per_code
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
    with connected(args) as dev:
        converted = not takes_codes(cal)
        cal = to_code_units(cal, nT_per_code(device_config(dev)))
        request = "set-cal " + json.dumps(cal.to_dict(), separators=(",", ":"))
        if len(request) > MAX_LINE:   # the firmware would drop it (line_too_long)
            raise CommandError("%s: %d bytes as a request, the firmware takes %d: trim its meta"
                               % (args.calibration, len(request), MAX_LINE))
        dev.ask(request)
        back = dev.ask("get-cal")["cal"]
    if back is None or not _same(back, cal):
        raise CommandError("the handheld accepted the calibration but reports another one back")
    print("pushed %s to %s%s: saved and in force" % (
        args.calibration, dev.port, " (converted from nT to its code units)" if converted else ""))
    print("  " + fit_figures(dict(cal.diagnostics, field=cal.field)))
    if cal.response is not None:
        print("  its survey output de-lagged with tau %s ms" % ", ".join("%.3f" % (1e3 * t) for t in cal.response["tau_s"]))
    return 0


def _same(record, cal, rel=1e-5):
    """The record the device reports back is `cal`, to the precision of a board's float32."""
    sent = [v for row in cal.matrix for v in row] + cal.offset + [cal.field]
    got = [v for row in record["matrix"] for v in row] + list(record["offset"]) + [record["field"]]
    return all(abs(a - b) <= rel * max(abs(a), abs(b), 1e-12) for a, b in zip(sent, got))
