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

import math

from shared import linalg
from shared.calibration import Calibration
from shared.codes import DEGENERATE_COVERAGE, NON_FINITE, NOT_ELLIPSOID, TOO_FEW_SAMPLES
from shared.moments import INDEX, bit_length, to_float
from shared.prior import Prior, make_prior
from shared.quadric import FRAC, UNIT, W_C, W_EXP, Problem, add_exp, sym

# Icosahedron vertices: a spherical 5-design, so averaging a degree-4
# polynomial of the direction over these 12 points is exact (used for the
# predicted full-sphere error, whose variance is quartic in the direction).
_PHI = (1.0 + 5.0 ** 0.5) / 2.0
_NORM = (1.0 + _PHI * _PHI) ** 0.5
_ICO = []
for _s1 in (1.0, -1.0):
    for _s2 in (1.0, -1.0):
        _ICO.append((0.0, _s1 / _NORM, _s2 * _PHI / _NORM))
        _ICO.append((_s1 / _NORM, _s2 * _PHI / _NORM, 0.0))
        _ICO.append((_s2 * _PHI / _NORM, 0.0, _s1 / _NORM))

# Residual rms above this share of the field is not a distorted sphere: the
# noisiest real MEMS log here (QMC5883L) scatters 6 % after the best fit, a
# hyperboloid 19 %.
MAX_MISFIT = 0.1



class FitError(Exception):
    """A calibration that cannot be trusted; .reason is a stable code."""

    def __init__(self, reason, message):
        super().__init__("%s: %s" % (reason, message))
        self.reason = reason
        self.message = message


def _log1p(x):
    # MicroPython's math has no log1p; near convergence x ~ 1e-12 and
    # log(1 + x) would round it away.
    if -1e-4 < x < 1e-4:
        return x - x * x / 2.0 + x * x * x / 3.0
    return math.log(1.0 + x)


def _finite_all(values):
    for x in values:
        if not linalg.isfinite(x):
            return False
    return True


def _initial_guesses(pb):
    """Algebraic quadric fit and a sphere fit, both from the float moments about C.

    Returns a list of (a, f) in the frame; the caller keeps the one with the
    lower exact objective. The algebraic fit (w.a + g.v = 1, origin at the data
    mean, which is inside any convex surface the data lie on) is good with wide
    coverage; the sphere fit is the safe start for a small cap.
    """
    num = pb.num
    nf = pb.nf
    e = pb.e
    u = pb.u

    def mu(exp):
        return num(to_float(u[INDEX[exp]], -e * (exp[0] + exp[1] + exp[2]))) / nf

    guesses = []
    feats = [(W_EXP[m], W_C[m]) for m in range(6)] + [(UNIT[i], 1) for i in range(3)]
    gram = [[mu(add_exp(fp[0], fq[0])) * num(float(fp[1] * fq[1])) for fq in feats] for fp in feats]
    rhs = [mu(fp[0]) * num(float(fp[1])) for fp in feats]
    try:
        sol = linalg.solve_spd(gram, rhs, num)
        am = sym(sol[:6])
        low = linalg.cholesky(am, num)
        half_g = [sol[6 + i] / num(2.0) for i in range(3)]
        centre = linalg.cho_solve(low, half_g)  # A c = g/2, b = -c ... sign below
        b = [-x for x in centre]
        kappa = num(1.0) + sum(b[i] * (am[i][0] * b[0] + am[i][1] * b[1] + am[i][2] * b[2]) for i in range(3))
        if kappa > num(0.0):
            guesses.append(([x / kappa for x in sol[:6]], b))
    except ValueError:
        pass
    # Sphere: |v|^2 + g.v + d = 0, linear least squares in (g, d).
    one = num(1.0)
    gram = [[mu(add_exp(UNIT[i], UNIT[j])) for j in range(3)] + [mu(UNIT[i])] for i in range(3)]
    gram.append([mu(UNIT[j]) for j in range(3)] + [one])
    rhs = []
    for i in range(3):
        rhs.append(-(mu(add_exp(UNIT[i], (2, 0, 0))) + mu(add_exp(UNIT[i], (0, 2, 0))) + mu(add_exp(UNIT[i], (0, 0, 2)))))
    rhs.append(-(mu((2, 0, 0)) + mu((0, 2, 0)) + mu((0, 0, 2))))
    try:
        sol = linalg.solve_spd(gram, rhs, num)
        b = [-sol[i] / num(2.0) for i in range(3)]
        r2 = b[0] * b[0] + b[1] * b[1] + b[2] * b[2] - sol[3]
        if r2 > num(0.0):
            inv = one / r2
            guesses.append(([inv, inv, inv, num(0.0), num(0.0), num(0.0)], b))
    except ValueError:
        pass
    return guesses


def _expm1(x):
    if -1e-4 < x < 1e-4:
        return x + x * x / 2.0 + x * x * x / 6.0
    return math.exp(x) - 1.0


def _isqrt(n):
    """floor(sqrt(n)) for a non-negative int of any size (Newton in integers)."""
    if n < 2:
        return n
    x = 1 << ((bit_length(n) + 1) // 2)
    while True:
        y = (x + n // x) // 2
        if y >= x:
            return x
        x = y


def _sqrt_third(tr, exponent):
    """sqrt(tr * 2^exponent / 3) for an int tr and an even exponent, rounded once."""
    j = max(0, (120 - bit_length(tr)) // 2)
    return to_float(_isqrt((tr << (2 * j)) // 3), exponent // 2 - j)


def _quantise(x):
    return int(round(math.ldexp(float(x), FRAC)))


class _State:
    def __init__(self, pb, prior, a_int, f_int):
        self.a_int = a_int
        self.f_int = f_int
        self.s = pb.sums_at(f_int)
        self.ga, self.t, self.rss = pb.exact(self.s, a_int)
        self.a = [pb.value(x, -FRAC) for x in a_int]
        self.f = [pb.value(x, -FRAC) for x in f_int]
        self.rho, self.jac = prior.residuals(self.a, self.f) if prior else ([], [])
        num = pb.num
        p = num(0.0)
        for r in self.rho:
            p = p + r * r
        self.prior_sq = p

    def worse_than(self, other, n):
        """Exact-where-it-matters comparison of objective (2): self - other > 0."""
        if self.rss <= 0 or other.rss <= 0:
            return self.rss > other.rss
        change = log_ratio(self.rss, other.rss)
        if change is None:
            return False   # underflowed: smaller than the other by far more than the prior can weigh
        return n * change + float(self.prior_sq - other.prior_sq) > 0.0


def log_ratio(mine, theirs):
    """log(mine / theirs) for two positive exact RSS integers; None if mine underflows.

    Both sums carry ~230 bits: scaled by the same power of two into the
    float's range first, since float(rss) is a silent inf on a
    single-precision port and inf/inf a nan that compares False.
    """
    s = -bit_length(theirs)
    a = to_float(mine, s)
    b = to_float(theirs, s)
    if not a > 0.0:
        return None
    rel = to_float(mine - theirs, s) / b
    # log1p near 0, where the exact difference carries the precision; the plain
    # ratio elsewhere (rounding can put rel at -1 when the two differ by orders)
    return _log1p(rel) if -1e-4 < rel < 1e-4 else math.log(a / b)

def _system(pb, st, gradient_only=False):
    """Normal matrix (None if gradient_only) and gradient of (2) at st."""
    if gradient_only:
        h = None
        g = pb.gradient(st.ga, st.t, sym(st.a))
    else:
        h, g, _ = pb.normal_equations(st.s, st.a_int, st.ga, st.t)
    if st.rho:
        num = pb.num
        lam = pb.value(st.rss, -6 * FRAC) / (pb.nf * pb.nf)  # (RSS/N)/N
        for r, row in zip(st.rho, st.jac):
            for i in range(9):
                if row[i] == num(0.0):
                    continue
                g[i] = g[i] + lam * row[i] * r
                if h is not None:
                    for k in range(9):
                        h[i][k] = h[i][k] + lam * row[i] * row[k]
    return h, g


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
    if not _finite_all([c for row in pb.cov for c in row]):
        raise FitError(NON_FINITE, "sample scatter overflows this number type")
    values, _ = linalg.eigh3(pb.cov, num)
    top = max(values)
    if not top > num(0.0):
        raise FitError(DEGENERATE_COVERAGE, "samples span no volume: rotate about more than one axis")
    return pb, k_nom, kr, float(min(values) / top)


def solve(sums, field=None, prior=None, num=float, scale=1.0, shape_sigma=(0.01, 0.0175),
          min_samples=12, max_iter=60, max_error=None, min_observability=1e-6):
    """See EllipsoidFit.solve (all nine parameters; a prior is a weak one); a Calibration or FitError."""
    return solve_state(sums, field, prior, num, scale, shape_sigma, min_samples, max_iter, max_error,
                       min_observability)[0]


def solve_state(sums, field=None, prior=None, num=float, scale=1.0, shape_sigma=(0.01, 0.0175),
                min_samples=12, max_iter=60, max_error=None, min_observability=1e-6):
    """solve(), also returning the converged state (its exact RSS: shared.quick's shape test)."""
    pb, k_nom, kr, observability = setup(sums, field, num, scale, min_samples)
    n = pb.n
    if prior is None and observability < min_observability:
        raise FitError(DEGENERATE_COVERAGE, "samples span no volume (observability %.2g): rotate about more than one axis" % observability)

    pr = make_prior(pb, prior, field, num, kr, k_nom, shape_sigma)

    best = None
    for a, f in _initial_guesses(pb):
        if not _finite_all(a) or not _finite_all(f):
            continue
        st = _State(pb, pr, [_quantise(x) for x in a], [_quantise(x) for x in f])
        if best is None or best.worse_than(st, n):
            best = st
    if best is None:
        raise FitError(NOT_ELLIPSOID, "no ellipsoid through the samples")

    st, h, iterations, rejected = iterate(pb, pr, best, num, max_iter)
    cal = _finish(pb, pr, st, field, num, kr, k_nom, observability, iterations, max_error, h)
    cal.diagnostics["rejected"] = rejected
    return cal, st

def _reduce(h, g, basis):
    """H and g of (2) in the coordinates of basis (columns p_k: dp = sum c_k p_k)."""
    hp = [[sum(h[i][j] * p[j] for j in range(9)) for i in range(9)] for p in basis]
    hr = [[sum(p[i] * q[i] for i in range(9)) for q in hp] for p in basis]
    gr = [sum(p[i] * g[i] for i in range(9)) for p in basis]
    return hr, gr


def iterate(pb, pr, st, num, max_iter, basis=None):
    """Levenberg-Marquardt on objective (2) from the state st.

    basis: None to move all nine parameters, or an object whose
    directions(st) are the directions they may move in (lists of 9 floats)
    and apply(st, step) turns a step in those coordinates into the integer
    changes (da, df) of the state. Returns (state, normal matrix or None, iterations,
    rejected steps); the normal matrix is the last one formed, returned where
    it is valid at the state (see below), in the basis' coordinates.
    """
    n = pb.n
    mu = 1e-3
    iterations = 0
    rejected = 0       # Levenberg-Marquardt steps refused for raising the objective
    h = None
    moved = small = False
    for iterations in range(1, max_iter + 1):
        h, g = _system(pb, st)
        if not _finite_all(g):
            raise FitError(NON_FINITE, "gradient is not finite")
        dirs = basis.directions(st) if basis else None
        if dirs:
            h, g = _reduce(h, g, dirs)
        k = len(g)
        moved = False
        small = False
        for _ in range(10):
            damped = [row[:] for row in h]
            for i in range(k):
                damped[i][i] = damped[i][i] * num(1.0 + mu)
            try:
                step = linalg.solve_spd(damped, [-x for x in g], num)
            except ValueError:
                mu = mu * 10.0 if mu > 0 else 1e-3
                continue
            if not _finite_all(step):
                raise FitError(NON_FINITE, "step is not finite")
            if dirs:
                da, df = basis.apply(st, step)
            else:
                da = [_quantise(x) for x in step[:6]]
                df = [_quantise(x) for x in step[6:]]
            if not any(da) and not any(df):
                break
            biggest = max(abs(float(x)) for x in step)
            cand = _State(pb, pr, [st.a_int[i] + da[i] for i in range(6)], [st.f_int[i] + df[i] for i in range(3)])
            # Near the fixed point the Gauss-Newton step is trusted even when
            # rounding hides the (tiny) decrease of the objective.
            if biggest < 1e-7 or not cand.worse_than(st, n):
                st = cand
                moved = True
                small = biggest < math.ldexp(1.0, 2 - FRAC)
                mu = mu / 10.0 if mu > 1e-9 else 0.0
                break
            rejected += 1
            mu = mu * 10.0 if mu > 0 else 1e-3
        if not moved or small:
            break

    # the error estimate needs the normal matrix at st: the last one was formed one step
    # before, and serves where that step was tiny or not taken, and for a quick solve
    # (max_iter <= 2: a device's provisional estimate) whose result is an estimate anyway
    if moved and not small and max_iter > 2:
        h = None
    return st, h, iterations, rejected


def _finish(pb, pr, st, field, num, kr, k_nom, observability, iterations, max_error, h=None, dirs=None):
    one = num(1.0)
    zero = num(0.0)
    am = sym(st.a)
    a_values, a_vectors = linalg.eigh3(am, num)
    if not min(a_values) > zero:
        raise FitError(NOT_ELLIPSOID, "fitted quadric is not an ellipsoid (eigenvalues %s)" % ", ".join("%.3g" % float(x) for x in a_values))

    # Shape E = A'/t - I with A' = K^-1 A K^-1; for equal nominal scales it is
    # formed from the exact integers, so |E| ~ 1e-2 carries full relative precision.
    if kr[0] == kr[1] == kr[2]:
        tr = st.a_int[0] + st.a_int[1] + st.a_int[2]
        trf = to_float(tr)
        e = [num(to_float(3 * st.a_int[m] - (tr if m < 3 else 0)) / trf) for m in range(6)]
    else:
        _, _, e = pr.shape(st.a) if pr else Prior(num, kr, [0.0] * 6, [1.0] * 6).shape(st.a)
    e_values, e_vectors = linalg.eigh3(sym(e), num)
    # G = sqrt(I + E) = I + X, X = V diag(l / (1 + sqrt(1 + l))) V^T: the small
    # part is computed on its own so float32 rounding acts on 1e-2, not on 1.
    x = linalg.sym_function(e_values, e_vectors, lambda l: l / (one + num(math.sqrt(float(one + l)))))
    # log det(I + E) = sum log1p(l); tr E = 0, so the sum is O(|E|^2) and is
    # best formed from the small eigenvalues themselves, not from a product
    # of numbers near 1.
    log_det = 0.0
    for l in e_values:
        log_det += _log1p(float(l))
    # t' = tr(K^-1 A_raw K^-1)/3 with A_raw = A_frame / 4^e (nominal-unit quadric scale).
    kn = [num(k) for k in k_nom]
    t_raw = (st.a[0] / (kn[0] * kn[0]) + st.a[1] / (kn[1] * kn[1]) + st.a[2] / (kn[2] * kn[2])) / num(3.0)
    t_raw = t_raw / num(math.ldexp(1.0, 2 * pb.e))
    # det(s G) = 1 fixes the gain when the field is unknown: s = det(I+E)^(-1/6) = 1 + sigma.
    sigma = _expm1(-log_det / 6.0)
    radius = num(1.0 + sigma) / num(math.sqrt(float(t_raw)))
    # M = c (I + Y) K. Each entry is assembled as c k_j delta_ij + c k_j Y_ij so
    # that the O(1) part is rounded once and the rest of the rounding acts on
    # |Y| ~ 1e-2 (float32: 3e-3 nT instead of 1e-2 nT at 50,000 nT).
    if field is None:
        y = [[num(sigma) * (one if i == j else zero) + num(1.0 + sigma) * x[i][j] for j in range(3)] for i in range(3)]
        ck = kn
        field_out = radius
    else:
        y = x
        field_out = num(float(field))
        if kn[0] == kn[1] == kn[2]:
            # c k = F sqrt(tr A_raw / 3), from the exact integer trace.
            c = num(float(field) * _sqrt_third(st.a_int[0] + st.a_int[1] + st.a_int[2], -FRAC - 2 * pb.e))
            ck = [c, c, c]
        else:
            c = field_out * num(math.sqrt(float(t_raw)))
            ck = [c * k for k in kn]
    matrix = [[(ck[j] if i == j else zero) + ck[j] * y[i][j] for j in range(3)] for i in range(3)]
    offset = [num(float(pb.centre[i]) + to_float(st.f_int[i], pb.e - FRAC)) for i in range(3)]

    rss = pb.value(st.rss, -6 * FRAC) / pb.nf
    rms = num(math.sqrt(float(rss))) / num(2.0) * field_out
    predicted = _predicted_error(pb, st, rss, am, a_values, a_vectors, num, h, dirs, field is None) * field_out

    flat = [v for row in matrix for v in row] + offset + [field_out, rms, predicted]
    if not _finite_all(flat):
        raise FitError(NON_FINITE, "calibration is not finite")
    if float(rms) > MAX_MISFIT * float(field_out):
        raise FitError(NOT_ELLIPSOID, "samples do not lie on an ellipsoid: residual %.3g rms is %.0f %% of the field" % (float(rms), 100.0 * float(rms) / float(field_out)))
    limit = max_error if max_error is not None else 0.01 * float(field_out)
    if float(predicted) > limit:
        raise FitError(DEGENERATE_COVERAGE, "predicted calibration error %.3g exceeds %.3g: rotate through more orientations" % (float(predicted), limit))
    diagnostics = {
        "n": pb.n,
        "rms": float(rms),
        "observability": observability,
        "predicted_error": float(predicted),
        "iterations": iterations,
        "radius": float(radius),
    }
    return Calibration([[float(v) for v in row] for row in matrix], [float(v) for v in offset], float(field_out), diagnostics)


def _sphere_gradients(a_values, a_vectors, am, num):
    """For each icosahedron direction u, the gradient g of the relative |h_c| error
    at v = A^-1/2 u on the fitted ellipsoid: g = (w(v)/2, -A v)."""
    inv_sqrt = linalg.sym_function(a_values, a_vectors, lambda l: num(1.0) / num(math.sqrt(float(l))))
    two = num(2.0)
    out = []
    for direction in _ICO:
        v = linalg.matvec(inv_sqrt, [num(c) for c in direction])
        av = linalg.matvec(am, v)
        out.append([v[0] * v[0] / two, v[1] * v[1] / two, v[2] * v[2] / two, v[0] * v[1], v[0] * v[2], v[1] * v[2],
                    -av[0], -av[1], -av[2]])
    return out


def _bias_sq(pb, st, rss, low, a_values, a_vectors, am, num, dirs, centred):
    """Mean square over the sphere of the relative |h_c| error of the state's offset
    from the truth that the noise does not average away: its bias, and the
    remaining step where the iteration stopped short.

    shared.quadric.Problem.noise_gradient: bias = -H^-1 s2 g, with the noise
    variance s2 from the residuals, rss = 4 s2 mean |A v|^2. Second order:
    nothing beside the spread on a wide cover, ~8x the spread on a 3 % cap at
    1 nT (desktop/bench/honesty.py). centred (field unknown): the part common
    to all directions is a bias of the fitted field, not an error that turns
    with the instrument, and is left out.
    """
    g, q = pb.noise_gradient(st.s, st.a)
    if not q > num(0.0):
        return num(0.0)
    s2 = rss / (num(4.0) * q)
    # Where the iteration stopped short of the fixed point (a long valley on a
    # small cap), the state is off by the remaining Gauss-Newton step too:
    # st - truth = (st - fixed point) + bias = H^-1 (gradient - s2 g).
    _, grad = _system(pb, st, True)
    g = [grad[i] - s2 * g[i] for i in range(9)]
    if dirs:
        g = [sum(p[i] * g[i] for i in range(9)) for p in dirs]
    bias = linalg.cho_solve(low, g)
    errs = []
    for gd in _sphere_gradients(a_values, a_vectors, am, num):
        if dirs:
            gd = [sum(p[i] * gd[i] for i in range(9)) for p in dirs]
        e = num(0.0)
        for i in range(len(gd)):
            e = e + gd[i] * bias[i]
        errs.append(e)
    k = num(float(len(errs)))
    mean = sum(errs) / k if centred else num(0.0)
    total = num(0.0)
    for e in errs:
        total = total + (e - mean) * (e - mean)
    return total / k


def _predicted_error(pb, st, rss, am, a_values, a_vectors, num, h=None, dirs=None, centred=False):
    """RMS over the sphere of the relative |h_c| error, from the posterior covariance.

    Cov(p) = (RSS/N) H^-1 with H the per-sample normal matrix of (2). For a true
    direction u the point on the fitted ellipsoid is v = A^-1/2 u and the
    relative magnitude error is g.dp with g = (w(v)/2, -A v).
    h: the normal matrix formed at or one tiny step before st (re-forming it
    costs ~2M instructions on a Cortex-M, docs/firmware.md), or None.
    dirs: the directions the fit was free to move in (a quick re-calibration's
    gain and offsets), h then in their coordinates; None for all nine.
    """
    if h is None:
        h, g = _system(pb, st)
        if dirs:
            h, _ = _reduce(h, g, dirs)
    try:
        low = linalg.cholesky(h, num)
    except ValueError:
        raise FitError(DEGENERATE_COVERAGE, "orientations seen leave the calibration undetermined: rotate about all axes")
    total = num(0.0)
    for g in _sphere_gradients(a_values, a_vectors, am, num):
        if dirs:
            g = [sum(p[i] * g[i] for i in range(9)) for p in dirs]
        y = linalg.cho_solve(low, g)
        for i in range(len(g)):
            total = total + g[i] * y[i]
    var = total / num(float(len(_ICO))) * rss / pb.nf
    var = var + _bias_sq(pb, st, rss, low, a_values, a_vectors, am, num, dirs, centred)
    if not var >= num(0.0):
        raise FitError(NON_FINITE, "covariance is not finite")
    return num(math.sqrt(float(var)))
