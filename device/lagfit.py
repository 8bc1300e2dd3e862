"""A calibration's estimate of the slow sensor's time constant, at the finish (session.py).

    steps_us, tau_sums = setup(cfg, taus_us, kind)   # (None, None): not estimated
    attach(session, delag)                     # survey.py: the gates take the steps from it
    final = estimate(session)                  # (fit, unit) at the estimated tau, or None
    problem = not_first_order(response, cal)   # (reason, message) or None

Samples de-lagged with the configured tau go through the gates into the fit, as without
the estimate; each accepted one also goes, with its tau step e (shared/delag.py), into four
more exact accumulators (shared/tausums.py), so the fit's sums are known exactly at any tau.
At the finish the fit is solved on a search over tau (one Gauss-Newton step each, as a
provisional solve) and the tau with the least residual taken: a lag left reads |B| long or
short by B (delta w)^2 / 2, which no ellipsoid absorbs where the turn rate varies. Its
uncertainty (shared/tausums.py minimise) replaces response_tol's in the record and in the
predicted error (session.py _widen). The gates keep deciding on the configured tau.

Not identified (the residual does not rise away from the least within response_tol: turned
too slowly to see the lag; or the least at the end of the reach): the configured tau stays,
and the record's response says so ("estimate"). A quick re-calibration keeps the configured
tau (it keeps the calibration in force's shape; its prior was fitted in code units).

Cost (docs/firmware.md): four more EllipsoidFit.add per accepted sample, four more sets of
35 sums (and 3 ints per removal-history entry), and ~8 one-step solves at the finish.
"""

from array import array

from gates import HIST
from shared import codes
from shared.codes import QUICK
from shared.delag import tau_us
from shared.fit import EllipsoidFit, FitError
from shared.tausums import NODES, TauSums, lagrange_sums, minimise

STEP = 0.1       # the nodes 10 % of the configured tau apart
_REACH = 5       # searched within 5 steps either side: a bandwidth configured up to 50 % wrong
_GRID = 64       # on a grid of 1/64 step (0.16 % of tau)
_MIN_SAMPLES = 60    # as a provisional solve (session.py)
_ITER = 1        # Gauss-Newton steps per solve of the search: the provisional solve's


def setup(cfg, taus_us, kind):
    """(per-axis tau steps in whole us, TauSums) for a session of this kind de-lagging with
    taus_us, with tau_estimate on; (None, None) otherwise, and for a quick re-calibration (its
    sums would not be used)."""
    if taus_us is None or not cfg["tau_estimate"] or kind == QUICK:
        return None, None
    return [max(1, tau_us(STEP * t / 1e6)) for t in taus_us], TauSums()


def attach(session, delag):
    """The gates take each accepted sample's tau steps from delag (its .ex .ey .ez)."""
    g = session.gates
    if session.tau_sums is not None and delag.taus_us is not None:
        g.lag = delag
        if g.tau_sums is None:
            g.hist_e = array("i", bytes(4 * 3 * HIST))
            g.tau_sums = session.tau_sums
            fits = session.tau_sums.fits     # the residuals' batch means at any tau too
            g.batches.attach(fits[NODES.index(-1)], fits[NODES.index(1)])


def estimate(s):
    """(EllipsoidFit of the samples at the estimated tau, scaled by its unit q; q), with the
    session's taus_us, response and removal history moved to that tau; None (nothing
    changed but the response's note) when it is not estimated or not identified."""
    g = s.gates
    if s.tau_sums is None or g.tau_sums is None or s.fit.n < _MIN_SAMPLES or s.quick():
        return None
    centre = s.fit.sums()
    nodes = s.tau_sums.sums()

    def rms_at(p, q):
        s.search_solves += 1
        try:
            cal = EllipsoidFit.from_sums(lagrange_sums(centre, nodes, p, q)).solve(
                field=None, scale=[k / q for k in s.k], max_iter=_ITER)
        except FitError:
            return None
        finally:
            # each solve takes about the DRDY ring's span on a Pico (0.2-0.35 s of its 1.28 s):
            # the main loop's service drains the ring and feeds the watchdog between them
            if s.between is not None:
                s.between()
        return cal.diagnostics.get("rms")

    t, sigma, _ = minimise(rms_at, centre[0], -_REACH, _REACH, _GRID)
    r = s.response
    if t is None or abs(t) >= _REACH:
        r["estimate"] = ("not identified: no least residual within %d %% of it (turned too slowly to see the lag: "
                         "the de-lag's noise alone is least at no lag; or a response far from the configured one)"
                         % (100 * _REACH * STEP))
        return None
    if sigma is None or sigma * STEP > s.cfg["response_tol"]:
        r["estimate"] = "not identified: the residual does not rise away from it (turned too slowly to see the lag)"
        return None
    p = round(t * _GRID)
    q = _GRID
    # the removal history (session.py residual_rho, recent_rms) at that tau too: x + (p / q) e
    h = g.hist
    he = g.hist_e
    for k in range(HIST):
        for a in range(3):
            j = 5 * k + a
            h[j] = (q * h[j] + p * he[3 * k + a] + (q >> 1)) // q
    s.taus_us = [tau_us((tu + p * su / q) / 1e6) for tu, su in zip(s.taus_us, s.steps_us)]
    r["tau_s"] = [tu / 1e6 for tu in s.taus_us]
    r["tau_sigma_s"] = [sigma * su / 1e6 for su in s.steps_us]
    r["source"] = "estimated"
    s.tau_t = p / q
    return EllipsoidFit.from_sums(lagrange_sums(centre, nodes, p, q)), q


def not_first_order(response, cal):
    """(reason, message) when the samples de-lagged with the estimated tau, the best first-order
    one, still leave residuals that follow each other (rho > 0.5; a first-order sensor's are
    about -0.1 to -0.2, the de-lag term's noise: docs/firmware.md); else None."""
    rho = cal.diagnostics.get("residual_rho")
    if response is None or response.get("source") != "estimated" or rho is None or rho <= 0.5:
        return None
    return codes.RESPONSE_NOT_FIRST_ORDER, "no first-order response undoes the sensor's lag"
