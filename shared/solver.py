"""Solve the ellipsoid fit from exact power sums (used by shared.fit.EllipsoidFit.solve).

With the residuals r of shared.quadric (eq. 1) we minimise the MAP objective

    L(A, b) = N log(sum r^2) + sum_k rho_k^2         (2)

where rho are weak prior residuals (shape of A near a sphere, or near a
previous calibration). Its stationarity condition is
sum r dr/dp + (RSS/N) sum rho drho/dp = 0: the prior is weighted by the fitted
residual variance, so it vanishes wherever the data are informative.

Why it is accurate in single precision: the parameters are held as
fixed-point integers (FRAC fractional bits), and at each Gauss-Newton step
the data gradient and the residual sum of squares are computed *exactly* in
integers from the power sums re-centred on the current b. Only the step
direction (normal matrix, 9x9) is computed in the chosen number type; an
approximate normal matrix changes how fast the iteration converges, never
where it converges (mixed-precision iterative refinement). Float32, 22-bit
CircuitPython floats and doubles therefore reach the same fixed point.
"""

from shared import linalg
from shared.codes import DEGENERATE_COVERAGE, NON_FINITE, NOT_ELLIPSOID, TOO_FEW_SAMPLES
from shared.errors import FitError
from shared.iteration import MAX_ITER, State, iterate, quantise
from shared.prior import SHAPE_SIGMA, make_prior
from shared.quadric import Problem
from shared.result import finish
from shared.start import initial_guesses

MIN_SAMPLES = 12            # fewer samples: too_few_samples (nine parameters and some to spare)
MIN_OBSERVABILITY = 1e-6    # samples' smallest spread / largest below this span no volume


def setup(sums, field, num, scale, min_samples):
    """Checks and the problem in its frame: (pb, k_nom, kr, observability)."""
    n = sums[0]
    if n < min_samples:
        raise FitError(TOO_FEW_SAMPLES, "%d samples, need at least %d" % (n, min_samples))
    k_nom = [float(scale)] * 3 if isinstance(scale, (int, float)) else [float(k) for k in scale]
    if len(k_nom) != 3 or not (k_nom[0] > 0 and k_nom[1] > 0 and k_nom[2] > 0):
        raise ValueError("scale must be a positive number or 3 positive numbers")
    if field is not None and not field > 0:
        raise ValueError("field must be positive")
    k_geo = (k_nom[0] * k_nom[1] * k_nom[2]) ** (1.0 / 3.0)
    kr = [k / k_geo for k in k_nom]

    pb = Problem(sums, num)
    if not linalg.all_finite([c for row in pb.cov for c in row]):
        raise FitError(NON_FINITE, "sample scatter overflows this number type")
    values, _ = linalg.eigh3(pb.cov, num)
    top = max(values)
    if not top > num(0.0):
        raise FitError(DEGENERATE_COVERAGE, "samples span no volume: rotate about more than one axis")
    return pb, k_nom, kr, float(min(values) / top)


def solve(sums, field=None, prior=None, num=float, scale=1.0, shape_sigma=SHAPE_SIGMA,
          min_samples=MIN_SAMPLES, max_iter=MAX_ITER, max_error=None, min_observability=MIN_OBSERVABILITY,
          between=None):
    """See EllipsoidFit.solve (all nine parameters; a prior is a weak one); a Calibration or FitError."""
    return solve_state(sums, field, prior, num, scale, shape_sigma, min_samples, max_iter, max_error,
                       min_observability, between)[0]


def solve_state(sums, field=None, prior=None, num=float, scale=1.0, shape_sigma=SHAPE_SIGMA,
                min_samples=MIN_SAMPLES, max_iter=MAX_ITER, max_error=None, min_observability=MIN_OBSERVABILITY,
                between=None):
    """solve(), also returning the converged state (its exact RSS: shared.quick's shape test)."""
    return solve_problem(setup(sums, field, num, scale, min_samples), field, prior, num, shape_sigma, max_iter,
                         max_error, min_observability, between)


def solve_problem(problem, field, prior, num, shape_sigma, max_iter, max_error, min_observability, between=None):
    """solve_state() on the problem setup() returned: shared.quick's shape test solves the problem
    of its own fit, one copy of the re-centred sums on a board's heap where two ran it out.
    between: None, or called after the initial guess and between the iterations (EllipsoidFit.solve)."""
    pb, k_nom, kr, observability = problem
    if prior is None and observability < min_observability:
        raise FitError(DEGENERATE_COVERAGE, "samples span no volume (observability %.2g): rotate about more than one axis" % observability)

    pr = make_prior(pb, prior, field, num, kr, k_nom, shape_sigma)
    st, h, iterations, rejected = iterate(pb, pr, _start(pb, pr, between), num, max_iter, None, between)
    cal = finish(pb, pr, st, field, num, kr, k_nom, observability, iterations, max_error, h)
    cal.diagnostics["rejected"] = rejected
    return cal, st


def _start(pb, pr, between=None):
    """The initial guess with the lower objective (2), as a State (in a function of its own so that
    the guess not taken is garbage before the iteration's states are built); between() after it."""
    best = None
    for a, f in initial_guesses(pb):
        if not linalg.all_finite(a) or not linalg.all_finite(f):
            continue
        st = State(pb, pr, [quantise(x) for x in a], [quantise(x) for x in f])
        if best is None or best.worse_than(st, pb.n):
            best = st
    if best is None:
        raise FitError(NOT_ELLIPSOID, "no ellipsoid through the samples")
    st = None
    if between is not None:
        between()
    return best
