"""The options that undo a slow sensor's lag (fit, correct). Not a command.

    add_lag_arguments(parser, lag=True)      # [--lag TAU_S|auto [--lag-prior TAU_S]] --rate SPS
    t = sample_times(args, path, h, t)      # (N,) s, or CommandError naming what is missing
"""

from desktop.cli._errors import CommandError


def add_lag_arguments(p, lag=True):
    g = p.add_argument_group("a slow sensor's lag (docs/cli.md, 'Slow sensors')")
    if lag:
        g.add_argument("--lag", metavar="TAU_S|auto", default=None,
                       help="undo a first-order sensor's lag before the fit: its time constant in s "
                            "(1 / (2 pi bandwidth): 0.0318 for 5 Hz), or auto to estimate one per axis from "
                            "the readings; the calibration carries it and `fluxcal correct` applies it")
        g.add_argument("--lag-prior", metavar="TAU_S", default=None,
                       help="with --lag auto: the configured time constant (s, e.g. the datasheet's bandwidth), "
                            "which seeds the estimate and stands, +-50 %%, where the data do not show the lag")
    g.add_argument("--rate", type=float, metavar="SPS", default=None,
                   help="the log's sample rate, when it has no time column (a capture .npz has its own)")


def parse_lag(text, option="--lag", auto=True):
    """'auto' (when auto) or a time constant in s (0..1); CommandError otherwise."""
    if auto and text == "auto":
        return "auto"
    try:
        tau = float(text)
    except ValueError:
        tau = float("nan")
    from shared.response import TAU_LIMIT_S
    if not 0.0 <= tau <= TAU_LIMIT_S:
        raise CommandError("%s must be %sa time constant in s, 0..%g (1 / (2 pi bandwidth))"
                           % (option, "auto or " if auto else "", TAU_LIMIT_S))
    return tau


def sample_times(args, path, n, t):
    """The sample times (n,) s: a capture's own, the log's time column, or n at --rate."""
    from desktop.methods.lag import times
    if path.endswith(".npz"):
        from desktop.formats.capture import load_capture
        t = load_capture(path)["t"]
    try:
        return times(n, t if args.rate is None else None, args.rate)
    except ValueError as exc:
        raise CommandError("%s: %s" % (path, exc))
