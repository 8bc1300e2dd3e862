"""`fluxcal experiment NAME -o DIR`: reproduce one of the paper's tables or figures."""

import os
import time

from desktop.cli._errors import CommandError

HELP = "reproduce a paper experiment (table1, table2, fig6, fig7, fig8, smearing, lag): PNG + markdown table"


def add_arguments(p):
    from desktop.experiments import EXPERIMENTS
    p.add_argument("name", choices=EXPERIMENTS + ("all",), help="which experiment")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="directory for the PNG and .md files")


def run(args):
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise CommandError("the experiments draw plots with matplotlib: pip install 'fluxcal[plots]'")
    from desktop.experiments import EXPERIMENTS, coverage, lag, smearing, tables
    runners = {"table1": tables.table1, "table2": tables.table2, "fig6": tables.fig6,
               "fig7": coverage.run, "fig8": coverage.run, "smearing": smearing.run,
               "lag": lag.run}
    try:
        os.makedirs(args.output, exist_ok=True)
    except OSError as exc:
        raise CommandError("cannot create %s: %s" % (args.output, exc))
    names = [n for n in EXPERIMENTS if n != "fig8"] if args.name == "all" else [args.name]
    for name in names:
        t0 = time.perf_counter()
        text = runners[name](args.output)
        print(text)
        print("(%s: %.1f s, written to %s)\n" % (name, time.perf_counter() - t0, args.output))
    return 0
