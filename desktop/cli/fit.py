"""fluxcal fit RAW -o CAL.json [--prior OLD.json] [--max-predicted NT | --accept-anyway]
    [--lag TAU_S|auto [--lag-prior TAU_S]]

The written calibration's predicted full-sphere error is desktop.methods.refusal's
predicted_error, the one `fluxcal report` gives too (the core's white-noise value
widened by the residuals' correlation in time, with a systematic floor); a
calibration predicted worse than --max-predicted is refused like the firmware
refuses it (reason predicted_error_too_high, device/acceptance.py), unless
--accept-anyway. A fit on samples that cover too little (degenerate_coverage) or
lie on no ellipsoid (not_ellipsoid) is never written. Each refusal names its cause
(refusal.cause).

--lag undoes a first-order sensor's lag before the fit (desktop.methods.lag): given, or
estimated per axis (auto), from a configured time constant when one is given
(--lag-prior: it seeds the estimate and stands where the data do not show the lag); then
the predicted error holds the estimate's uncertainty too, a response the data cannot
identify is warned of (response_not_identified), and one that is not first order is
refused (response_not_first_order; --accept-anyway writes it with the warning).
"""

import os
import sys

from desktop.cli._errors import CommandError
from desktop.cli._lag_options import add_lag_arguments, parse_lag, sample_times
from desktop.cli._log_options import add_log_arguments, log_format
from shared.codes import MAX_PREDICTED_NT

RESPONSE_NOT_FIRST_ORDER = "response_not_first_order"   # --lag auto's model check (desktop.methods.lag)
RESPONSE_NOT_IDENTIFIED = "response_not_identified"     # --lag auto: the lag not seen in the data
HELP = "fit a calibration to raw readings (a magnetometer log: CSV or text columns, any unit; or a capture .npz)"



def add_arguments(p):
    from desktop.methods import METHODS     # numpy, so here: `import desktop.cli` stays light

    p.add_argument("raw", help="magnetometer log (CSV or whitespace-separated, in time order; see --columns, --unit) "
                               "or a capture .npz")
    p.add_argument("-o", "--output", required=True, help="calibration JSON to write")
    p.add_argument("--method", choices=METHODS, default="streaming",
                   help="streaming (the device's own fit, default), algebraic, mle or paper-nn")
    p.add_argument("--field", type=float, default=None, help="known local field magnitude, nT")
    p.add_argument("--float32", action="store_true", help="run the streaming solve in 32-bit floats, as most boards do")
    p.add_argument("--prior", metavar="OLD.json", default=None,
                   help="a previous calibration of this sensor: quick re-calibration (offsets and common gain, "
                        "its shape kept unless the data say otherwise; streaming only)")
    p.add_argument("--max-predicted", type=float, default=MAX_PREDICTED_NT, metavar="NT",
                   help="refuse (exit 1, nothing written) when the predicted full-sphere error exceeds this, nT "
                        "(default %(default)g, the firmware's max_predicted_nt)")
    p.add_argument("--accept-anyway", action="store_true",
                   help="write the calibration even when its predicted error exceeds --max-predicted (a warning); "
                        "never when the samples cover too little or lie on no ellipsoid")
    add_log_arguments(p)
    add_lag_arguments(p)


def _load_prior(path):
    from desktop.formats.calibration import load_calibration, plausibility_problem, takes_codes, to_nT_units

    prior = load_calibration(path)
    if takes_codes(prior):
        scale = prior.meta.get("scale")
        if scale is None:
            raise CommandError("%s takes ADC codes and has no meta.scale (nT per code) to convert it" % path)
        prior = to_nT_units(prior, scale)
    problem = plausibility_problem(prior)
    if problem:
        raise CommandError("%s: not a plausible calibration: %s" % (path, problem))
    return prior


def run(args):
    from desktop.cli._show import predicted_text
    from desktop.formats.calibration import save_calibration
    from desktop.formats.readings import read_log
    from desktop.methods import fit_array
    from desktop.methods.lag import delag_taps
    from desktop.methods.refusal import predicted_error, problem
    from shared.fit import FitError

    if args.field is not None and not args.field > 0:
        raise CommandError("--field must be a positive number of nT")
    if args.float32 and args.method != "streaming":
        raise CommandError("--float32 applies to the streaming method only")
    if args.prior is not None and args.method != "streaming":
        raise CommandError("--prior applies to the streaming method only (a quick re-calibration of the device's fit)")
    if not args.max_predicted > 0:
        raise CommandError("--max-predicted must be a positive number of nT")
    prior = _load_prior(args.prior) if args.prior is not None else None
    h, t = read_log(args.raw, log_format(args))
    lag = _undo_lag(args, h, t) if args.lag is not None else None
    if lag is not None:
        h = lag["h"]
    try:
        # no limit in the core: the limits are checked below on the one predicted error, with their cause
        cal = fit_array(h, args.method, field=args.field, float32=args.float32, prior=prior, max_error=float("inf"))
    except FitError as exc:
        raise CommandError("calibration failed (%s): %s" % (exc.reason, exc.message))
    except (ValueError, ArithmeticError) as exc:
        raise CommandError("calibration failed (%s): %s" % (args.method, exc))
    # where it de-lagged h, the de-lag term's telescoping noise is taken off as the board takes it
    honest = predicted_error(cal, h, pinned=args.field is not None or prior is not None,
                             delag=None if lag is None else delag_taps(lag["t"], lag["response"]["tau_s"]))
    d = cal.diagnostics
    if lag is not None:
        _add_tau_error(cal, h, honest, lag)
    predicted = honest["predicted_error"]
    refused = problem(cal, h, honest, args.max_predicted)
    if refused and lag is not None and lag["message"]:
        refused = (refused[0], refused[1] + "; " + lag["message"], refused[2])
    elif refused and lag is not None and lag["response"]["source"] == "given":
        # a tau off by a few % leaves errors that follow the motion: say what estimates it
        refused = (refused[0], refused[1] + "; or the given tau is not the sensor's: estimate it from the "
                   "readings (--lag auto --lag-prior %s)" % args.lag, refused[2])
    elif lag is not None and not lag["model_ok"]:
        # the calibration may be fine, but correcting with this response leaves the turning's error
        refused = (RESPONSE_NOT_FIRST_ORDER, lag["message"], True)
    if refused and not refused[2]:
        raise CommandError("calibration failed (%s): %s" % refused[:2])
    if refused and not args.accept_anyway:
        raise CommandError("calibration refused (%s): %s" % refused[:2])
    if lag is not None:
        cal.response = lag["response"]
    cal.meta["method"] = args.method
    cal.meta["source"] = args.raw
    temp = _mean_die_temperature(args.raw)
    if temp is not None:   # what fluxcal tempco needs to fit coefficients across calibrations
        cal.meta["temperature_c"] = round(temp, 2)
    if args.prior is not None:
        cal.meta["prior"] = os.path.basename(args.prior)[-200:]
    save_calibration(args.output, cal)
    print("%s: %d samples, field %.2f nT, residual rms %.3f nT" % (args.method, d.get("n", len(h)), cal.field, d.get("rms", float("nan"))))
    if prior is not None:
        print("prior %s: %s" % (args.prior, "mode %s" % d["mode"] if "mode" in d else "used as a weak prior (no mode reported)"))
    if predicted is not None:
        print("%s (%s), observability %.3f" % (predicted_text(predicted), _widening(honest), d["observability"]))
    else:
        print("no predicted error for the %s method: not checked against --max-predicted" % args.method)
    if lag is not None:
        print(_lag_text(lag))
        if lag["message"] and not refused:
            print("fluxcal: warning: %s: %s" % (RESPONSE_NOT_IDENTIFIED, lag["message"]), file=sys.stderr)
    if refused:
        print("fluxcal: warning: %s: %s; written anyway (--accept-anyway)" % refused[:2], file=sys.stderr)
    return 0


def _undo_lag(args, h, t):
    """dict: h de-lagged, response (the record's), tau_cov (3, 3) s^2, message, raw h and t."""
    import numpy as np

    from desktop.methods.lag import delag, estimate_response
    how = parse_lag(args.lag)
    prior = None if args.lag_prior is None else parse_lag(args.lag_prior, "--lag-prior", auto=False)
    if prior is not None and how != "auto":
        raise CommandError("--lag-prior seeds an estimate: give it with --lag auto")
    t = sample_times(args, args.raw, len(h), t)
    if how == "auto":
        est = estimate_response(h, t, field=args.field, prior=prior)
        tau, sigma, cov, message = est["tau_s"], est["tau_sigma_s"], est["tau_cov_s2"], est["message"]
        model_ok = est["model_ok"]
    else:
        tau, sigma, cov, message, model_ok = np.full(3, how), np.zeros(3), np.zeros((3, 3)), "", True
    response = {"model": "first-order", "tau_s": [float(v) for v in tau],
                "tau_sigma_s": [float(v) for v in sigma], "source": "estimated" if how == "auto" else "given"}
    if prior is not None:
        response["prior_s"] = prior
    return {"h": delag(h, t, tau), "raw": h, "t": t, "response": response, "tau_cov": cov, "message": message,
            "model_ok": model_ok}


def _add_tau_error(cal, h, honest, lag):
    """The taus' uncertainty (lag.tau_error) in quadrature with the predicted error of a
    de-lagged fit (refusal.predicted_error: the de-lag term's telescoping noise taken off the
    residuals' rms, shared.honest.delag_share, as the board takes it)."""
    import math

    from desktop.methods.lag import tau_error
    if honest["predicted_error"] is None:
        return
    err = 0.0
    if lag["tau_cov"].any():
        err = tau_error(lag["raw"], lag["t"], lag["response"]["tau_s"], lag["tau_cov"], cal.field)
    honest["predicted_error"] = math.hypot(honest["predicted_error"], err)
    cal.diagnostics.update(predicted_error=honest["predicted_error"], tau_error=err)


def _lag_text(lag):
    r = lag["response"]
    taus = ", ".join("%.3f +- %.2g" % (1e3 * a, 1e3 * s) for a, s in zip(r["tau_s"], r["tau_sigma_s"]))
    return "lag undone (first order, %s): tau %s ms" % (r["source"], taus)


def _widening(honest):
    """How the predicted error came from the core's: the residuals' correlation, the floor."""
    text = "%.3f nT if the residuals were independent" % honest["predicted_error_white"]
    if honest["tau_int"] > 1.0:
        text += "; they follow each other over %.1f samples" % honest["tau_int"]
    if honest["applied_floor"]:
        text += "; systematic floor %.3f nT" % honest["applied_floor"]
    return text


def _mean_die_temperature(path):
    """The mean ADS1292 die temperature of a capture (.npz), or None (a CSV carries none)."""
    if not path.endswith(".npz"):
        return None
    from desktop.formats.capture import load_capture, temperature_from_codes
    try:
        t = temperature_from_codes(load_capture(path))
    except (KeyError, ValueError):
        return None
    return float(t.mean()) if len(t) else None
