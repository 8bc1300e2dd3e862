"""The `fluxcal` command line: a table of sub-commands (after mpremote's main.py).

Each sub-command is a module of this package (fit.py, correct.py, pull-cal is
pull_cal.py, ...; modules starting with _ are helpers the commands share), named
in COMMANDS, with ``HELP`` (one line), ``add_arguments(parser)`` and
``run(args) -> int``; what only one command needs (the simulator, the firmware
runner, numpy, matplotlib) is imported inside its ``run`` (or ``add_arguments``
when its choices need it), so importing the table stays light and `fluxcal fit`
does not pay for the others. A handler raises
:class:`CommandError` (or a file format's FormatError) for anything the user
can fix; ``main`` prints it as one line ``fluxcal: message`` and exits 1,
never with a traceback.
"""

import argparse
import sys

from desktop.cli import (calibrate, capture, correct, demo, deploy, emulate, experiment, fit, monitor, pull_cal,
                         push_cal, report, simulate, status, tempco)
from desktop.cli._errors import CommandError
from desktop.formats import FormatError

# name -> module, in the order `fluxcal --help` lists them
COMMANDS = {
    "fit": fit,
    "tempco": tempco,
    "correct": correct,
    "demo": demo,
    "simulate": simulate,
    "experiment": experiment,
    "status": status,
    "calibrate": calibrate,
    "monitor": monitor,
    "capture": capture,
    "pull-cal": pull_cal,
    "push-cal": push_cal,
    "report": report,
    "emulate": emulate,
    "deploy": deploy,
}

__all__ = ["COMMANDS", "CommandError", "build_parser", "main"]


def build_parser():
    parser = argparse.ArgumentParser(
        prog="fluxcal",
        description="In-field scalar calibration of a three-axis fluxgate magnetometer.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, module in COMMANDS.items():
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args._run(args) or 0
    except (CommandError, FormatError) as exc:
        print("fluxcal: %s" % exc, file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("fluxcal: interrupted", file=sys.stderr)
        return 130
