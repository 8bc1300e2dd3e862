"""The `fluxcal` command line: a table of sub-commands (after mpremote's main.py).

Each sub-command is a module of this package (fit.py, correct.py, pull-cal is
pull_cal.py, ...; modules starting with _ are helpers the commands share) with
``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``; what
only one command needs (the simulator, the firmware runner, matplotlib) is
imported inside its ``run``, so `fluxcal fit` does not pay for the others. A handler raises
:class:`CommandError` (or a file format's FormatError) for anything the user
can fix; ``main`` prints it as one line ``fluxcal: message`` and exits 1,
never with a traceback.
"""

import argparse
import importlib
import sys

from desktop.formats import FormatError

COMMANDS = ("fit", "tempco", "correct", "demo", "simulate", "experiment",
            "status", "calibrate", "monitor", "capture", "pull-cal", "push-cal", "report", "emulate",
            "deploy")


class CommandError(Exception):
    """A user-facing failure: printed as one line `fluxcal: message`, exit code 1."""


def build_parser():
    parser = argparse.ArgumentParser(
        prog="fluxcal",
        description="In-field scalar calibration of a three-axis fluxgate magnetometer.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        module = importlib.import_module("desktop.cli." + name.replace("-", "_"))
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
