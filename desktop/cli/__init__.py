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
never with a traceback. A module that only an optional extra brings (EXTRAS) is
named in one line with the extra that brings it; a reader that goes away (`fluxcal
status | head -3`) ends the command quietly, as it ends cat.
"""

import argparse
import os
import signal
import sys

from desktop.cli import (calibrate, capture, correct, demo, deploy, emulate, experiment, fit, map, monitor,
                         pull_cal, push_cal, report, simulate, status, survey, tempco)
from desktop.cli._errors import CommandError
from desktop.formats import FormatError

# name -> module, in the order `fluxcal --help` lists them
COMMANDS = {
    "fit": fit,
    "tempco": tempco,
    "correct": correct,
    "demo": demo,
    "simulate": simulate,
    "survey": survey,
    "map": map,
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

# the top-level module an optional extra of the package brings -> that extra (pyproject.toml)
EXTRAS = {"matplotlib": "plots", "mpl_toolkits": "plots", "pynmea2": "gps"}

__all__ = ["COMMANDS", "CommandError", "EXTRAS", "build_parser", "main", "version"]


def version():
    """fluxcal's version as installed, else (a checkout not installed) pyproject.toml's."""
    from importlib import metadata
    try:
        return metadata.version("fluxcal")
    except metadata.PackageNotFoundError:
        return "0.1.0+checkout"


class _Version(argparse.Action):
    """--version: the package's and the firmware's version, read only when asked."""

    def __init__(self, option_strings, dest, **kw):
        super().__init__(option_strings, dest, nargs=0, help="print the version of fluxcal and its firmware")

    def __call__(self, parser, namespace, values, option_string=None):
        from desktop.firmware.deploy import firmware_version
        from shared import codes
        print("fluxcal %s (firmware %s, protocol %s)" % (version(), firmware_version(), codes.PROTOCOL_VERSION),
              flush=True)     # before parser.exit: a closed pipe is then main's to catch
        parser.exit()


class _Parser(argparse.ArgumentParser):
    """A bad option is bad input: one line and exit 1, as every command's own refusals (not
    argparse's usage block and exit 2); the subcommands' parsers are of this class too."""

    def error(self, message):
        self.exit(1, "fluxcal: %s (%s --help)\n" % (message, self.prog))


def build_parser():
    parser = _Parser(
        prog="fluxcal",
        description="In-field scalar calibration of a three-axis fluxgate magnetometer.",
    )
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, module in COMMANDS.items():
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv=None):
    args = None
    try:
        args = build_parser().parse_args(argv)
        code = args._run(args) or 0
        sys.stdout.flush()      # here, where a closed pipe is caught, not at the interpreter's exit
        return code
    except (CommandError, FormatError) as exc:
        print("fluxcal: %s" % exc, file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("fluxcal: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of standard output went away: nothing more to say to it (Python's own
        # advice: standard output onto devnull, so the exit's flush does not fail again)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except ModuleNotFoundError as exc:
        top = (exc.name or "").split(".")[0]
        if top not in EXTRAS:
            raise       # a module fluxcal always installs is missing: a broken install, shown as it is
        print("fluxcal: %s needs %s, which is not installed: pip install 'fluxcal[%s]'"
              % (args.command if args else "this", top, EXTRAS[top]), file=sys.stderr)
        return 1
