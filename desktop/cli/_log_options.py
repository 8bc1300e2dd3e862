"""The options that say how to read a magnetometer log (fit, correct, report). Not a command.

    add_log_arguments(parser, time=True)     # --columns --unit --scale --skip [--time-column]
    fmt = log_format(args)                   # desktop.formats.readings.LogFormat
"""

UNITS = ("nT", "uT", "mG", "G", "counts")    # desktop.formats.readings.UNITS_NT's keys
# the spellings loggers and people use for them, case aside
_SPELLINGS = {"nt": "nT", "nanotesla": "nT", "ut": "uT", "\u00b5t": "uT", "\u03bct": "uT", "microtesla": "uT",
              "mg": "mG", "milligauss": "mG", "g": "G", "gauss": "G", "count": "counts", "counts": "counts"}


def _unit(text):
    return _SPELLINGS.get(text.strip().lower(), text)    # anything else: argparse names the choices


def add_log_arguments(p, time=False):
    g = p.add_argument_group("reading a text log (CSV or whitespace-separated, with or without a header)")
    g.add_argument("--columns", metavar="X,Y,Z",
                   help="the field's three columns, header names or 0-based indices (default: found by name, "
                        "e.g. x,y,z, mx,my,mz, mag_x.., flux_a_x_nT..; or the only three columns)")
    g.add_argument("--unit", type=_unit, choices=UNITS, default="nT",
                   help="the log's unit: nT (default), uT, mG, G (gauss) or counts (needs --scale)")
    g.add_argument("--scale", type=float, metavar="NT_PER_COUNT",
                   help="nT per count of a log in counts (the sensor's datasheet: 1 G = 100,000 nT)")
    g.add_argument("--skip", type=int, default=0, metavar="N",
                   help="lines to skip before the header or the data (metadata a logger writes first)")
    if time:
        g.add_argument("--time-column", metavar="NAME|INDEX",
                       help="the column of time in seconds (default: one named t, time, sec, timestamp, ...; "
                            "time_ms is read as ms); without one, samples are numbered")


def log_format(args):
    from desktop.formats.readings import LogFormat

    return LogFormat(columns=args.columns, unit=args.unit, scale=args.scale, skip=args.skip,
                     time_column=getattr(args, "time_column", None))
