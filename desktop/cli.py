"""The `fluxcal` command line: a table of sub-commands (after mpremote's main.py).

Each sub-command lives in ``desktop/commands/<name>.py`` with ``HELP`` (one line),
``add_arguments(parser)`` and ``run(args) -> int``. Handlers raise
:class:`desktop.errors.CommandError` for anything the user can fix; ``main``
prints it as one line and exits 1, never with a traceback.
"""

import argparse
import importlib
import sys

from desktop.errors import CommandError

# name -> module under desktop.commands (imported lazily: `fluxcal fit` must not
# pay for matplotlib or the simulator).
COMMANDS = {
    "fit": "fit",
    "correct": "correct",
    "demo": "demo",
    "simulate": "simulate",
    "experiment": "experiment",
}


def build_parser():
    parser = argparse.ArgumentParser(
        prog="fluxcal",
        description="In-field scalar calibration of a three-axis fluxgate magnetometer.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, module_name in COMMANDS.items():
        module = importlib.import_module("desktop.commands." + module_name)
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args._run(args) or 0
    except CommandError as exc:
        print("fluxcal: %s" % exc, file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("fluxcal: interrupted", file=sys.stderr)
        return 130
