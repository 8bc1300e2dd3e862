"""fluxcal report CAPTURE [--cal CAL.json] -o DIR: what a capture and its calibration look like.

Prints the verdict first ("good to X nT over the sphere; to improve: ...",
desktop/views/verdict.py) and a warning when the recording covers too little of
the sphere; writes DIR/summary.md, which opens with the same lines, and six PNGs
(_report_figures.py): the coverage of the sphere and the error by direction on
equal-area maps, the residual against the rotation rate, the raw readings on
their ellipsoid beside the corrected ones on their sphere, |B| before and
after over time, and the histogram of the residuals |h_c| - field. Without
--cal the capture is fitted here first (--method, the device's own streaming
fit by default) as `fluxcal fit` fits it, with the same predicted error
(desktop.methods.refusal). A calibration that carries a response (fluxcal fit --lag) has
the readings' lag undone first, as `fluxcal correct` does: the corrected |B| is the
de-lagged one (the times: the capture's, the log's time column, or --rate).
"""

import os

from desktop.cli._errors import CommandError
from desktop.cli._lag_options import add_lag_arguments, sample_times
from desktop.cli._log_options import add_log_arguments, log_format

HELP = ("a verdict, PNG plots and a markdown summary of a capture: coverage and error on the sphere, residual"
        " against rotation rate, raw ellipsoid vs corrected sphere, |B|, residuals")
COVERAGE_MAX = 50000     # samples counted into the coverage cells
CELLS = 4                # cells per cube-face edge: the firmware's default (96 cells)


def add_arguments(p):
    from desktop.methods import METHODS     # numpy, so here: `import desktop.cli` stays light

    p.add_argument("capture", help="capture .npz (fluxcal capture or simulate) or a magnetometer log "
                                   "(CSV or whitespace-separated; see --columns, --unit, --time-column)")
    p.add_argument("--cal", metavar="CAL.json", help="calibration (fluxcal fit or pull-cal); default: fit here")
    p.add_argument("--method", choices=METHODS, default="streaming", help="the fit without --cal")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="folder for summary.md and the PNGs")
    add_log_arguments(p, time=True)
    add_lag_arguments(p, lag=False)


def run(args):
    import matplotlib  # noqa: F401 - the plots extra, asked for before any output (cli EXTRAS: one line)
    import numpy as np

    from desktop.cli._report_figures import write_figures
    from desktop.formats.readings import read_log
    from desktop.views.verdict import coverage_counts, verdict
    from desktop.methods import correct_array
    from desktop.methods.lag import delag, span_samples

    h, t_log = read_log(args.capture, log_format(args))
    capture = _capture_arrays(args.capture)
    cal, source = _calibration(args, h, capture)
    if capture is not None and len(capture.get("t", ())) == len(h):
        t = capture["t"]
    else:    # a log's time column, or (None) the figures number the samples
        t = t_log
    if cal.response is not None:     # the raw figures keep the readings as read; |B| is de-lagged
        ts = sample_times(args, args.capture, len(h), t_log)
        h_in = delag(h, ts, cal.response["tau_s"])
        source += ", lag undone (tau %s ms)" % ", ".join("%.3f" % (1e3 * v) for v in cal.response["tau_s"])
        # the derivative's first and last 2k samples are one-sided (desktop/methods/lag.py): at a
        # turning hand's rate they read |B| off by nT, so the figures leave them out
        edge = 2 * span_samples(ts)
        if len(h) > 4 * edge:
            h, h_in = h[edge:-edge], h_in[edge:-edge]
            t = None if t is None else t[edge:-edge]
            source += ", its first and last %d samples (one-sided) left out" % edge
    else:
        h_in = h
    corrected = correct_array(cal, h_in)
    timed = t is not None
    counts = coverage_counts(corrected, CELLS, COVERAGE_MAX)
    head, warnings = verdict(cal.diagnostics.get("predicted_error"), counts, CELLS, corrected, cal.field,
                             t if timed else np.arange(len(h), dtype=float), timed, fit_rms=cal.diagnostics.get("rms"))
    print(head)
    for line in warnings:
        print(line)
    try:
        os.makedirs(args.output, exist_ok=True)
    except OSError as exc:
        raise CommandError("%s: %s" % (args.output, exc.strerror or exc))
    figures = write_figures(args.output, h, corrected, t, cal, counts, CELLS)
    summary = os.path.join(args.output, "summary.md")
    try:
        with open(summary, "w") as fh:
            fh.write(_summary(args.capture, h, corrected, t, cal, source, counts, figures, timed, [head] + warnings))
    except OSError as exc:
        raise CommandError("%s: %s" % (summary, exc.strerror or exc))
    resid = np.linalg.norm(corrected, axis=1) - cal.field
    print("wrote %s and %d plots: %d samples, corrected |B| peak-to-peak %.3f nT, residual rms %.3f nT"
          % (summary, len(figures), len(h), np.ptp(resid), np.sqrt(np.mean(resid ** 2))))
    return 0


def _capture_arrays(path):
    if not path.endswith(".npz"):
        return None
    from desktop.formats.capture import load_capture
    return load_capture(path)


def _calibration(args, h, capture):
    """(Calibration taking nT, where it came from)."""
    from desktop.formats.calibration import load_calibration, takes_codes, to_nT_units
    from desktop.methods import fit_array
    from desktop.methods.refusal import predicted_error, problem
    from shared.fit import FitError

    if args.cal:
        cal = load_calibration(args.cal)
        if takes_codes(cal):
            if capture is None:
                raise CommandError("%s takes ADC codes; %s has no nT_per_code to convert it (use a .npz)"
                                   % (args.cal, args.capture))
            cal = to_nT_units(cal, capture["nT_per_code"])
        return cal, "`%s`" % args.cal
    try:
        cal = fit_array(h, args.method, max_error=float("inf"))     # the limit: refusal.problem, with its cause
    except FitError as exc:
        raise CommandError("%s: the fit failed (%s): %s" % (args.capture, exc.reason, exc.message))
    except (ValueError, ArithmeticError) as exc:
        raise CommandError("%s: the fit failed (%s): %s" % (args.capture, args.method, exc))
    # the report shows any predicted error, but not a fit the samples do not determine
    refused = problem(cal, h, predicted_error(cal, h, pinned=False), float("inf"))
    if refused and not refused[2]:
        raise CommandError("%s: the fit failed (%s): %s" % ((args.capture,) + refused[:2]))
    return cal, "fitted here (%s, %d samples)" % (args.method, len(h))


def _summary(path, h, corrected, t, cal, source, counts, figures, timed, verdict_lines):
    import numpy as np

    raw = np.linalg.norm(h, axis=1)
    mag = np.linalg.norm(corrected, axis=1)
    resid = mag - cal.field
    d = cal.diagnostics

    def figs(x):
        return "mean %.3f nT, peak-to-peak %.3f nT, std %.3f nT" % (x.mean(), np.ptp(x), x.std())

    rows = [("samples", "%d" % len(h) + (" over %.1f s" % (t[-1] - t[0]) if timed else "")),
            ("calibration", source),
            ("field of the calibration", "%.3f nT" % cal.field),
            ("raw \\|B\\|", figs(raw)),
            ("corrected \\|B\\|", figs(mag)),
            ("residual \\|h_c\\| - field", "rms %.3f nT, largest %.3f nT" % (np.sqrt(np.mean(resid ** 2)),
                                                                            np.abs(resid).max())),
            ("sphere covered", "%.0f %% of %d cells" % (100.0 * sum(1 for c in counts if c) / len(counts),
                                                       len(counts)))]
    for key, label, fmt in (("predicted_error", "predicted full-sphere error", "%.3f nT"),
                            ("observability", "observability", "%.3f"), ("rms", "fit residual rms", "%.3f nT")):
        if d.get(key) is not None:
            rows.append((label, fmt % d[key]))
    out = ["# fluxcal report: `%s`" % os.path.basename(path), ""]
    out += ["**%s**" % verdict_lines[0], ""] + ["> %s" % w for w in verdict_lines[1:]]
    out += ["", "| | |", "|---|---|"]
    out += ["| %s | %s |" % r for r in rows]
    out.append("")
    for name, title in figures:
        out += ["## %s" % title, "", "![%s](%s)" % (title, name), ""]
    return "\n".join(out)
