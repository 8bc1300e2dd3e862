"""fluxcal pull-cal -o CAL.json: the calibration in force on the handheld, validated, to a file."""

from desktop.cli._errors import CommandError
from desktop.cli._device import add_port_arguments, connected, device_config, nT_per_code, save_device_calibration

HELP = "save the handheld's calibration in force to a JSON file (in ADC code units)"


def add_arguments(p):
    p.add_argument("-o", "--output", required=True, metavar="CAL.json", help="calibration JSON to write")
    add_port_arguments(p)


def run(args):
    from desktop.cli._show import calibration_lines

    with connected(args) as dev:
        record = dev.ask("get-cal")["cal"]
        scale = nT_per_code(device_config(dev))
    if record is None:
        raise CommandError("the handheld on %s holds no calibration (fluxcal calibrate first)" % dev.port)
    save_device_calibration(record, scale, args.output)
    print("wrote %s (from %s; h_c = matrix (codes - offset), nT)" % (args.output, dev.port))
    for line in calibration_lines(record):
        print("  " + line)
    return 0
