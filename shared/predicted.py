"""The predicted full-sphere calibration error: what an operator would see turning the
instrument anywhere, from the posterior covariance and the bias the noise leaves.

    e = predicted_error(pb, st, rss, am, a_values, a_vectors, num, h, dirs, centred)
    # relative to the field; shared.result multiplies it by the field
"""

import math

from shared import linalg
from shared.codes import DEGENERATE_COVERAGE, NON_FINITE
from shared.errors import FitError
from shared.iteration import in_basis, system

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


def _sphere_gradients(a_values, a_vectors, am, num):
    """For each icosahedron direction u, the gradient g of the relative |h_c| error
    at v = A^-1/2 u on the fitted ellipsoid: g = (w(v)/2, -A v). shared.linalg_native puts
    linalgc's in its place on a board that has it (the same bits)."""
    inv_sqrt = linalg.sym_function(a_values, a_vectors, lambda l: num(1.0) / num(math.sqrt(float(l))))
    two = num(2.0)
    out = []
    for direction in _ICO:
        v = linalg.matvec(inv_sqrt, [num(c) for c in direction])
        av = linalg.matvec(am, v)
        out.append([v[0] * v[0] / two, v[1] * v[1] / two, v[2] * v[2] / two, v[0] * v[1], v[0] * v[2], v[1] * v[2],
                    -av[0], -av[1], -av[2]])
    return out


def _bias_sq(pb, st, rss, low, grads, num, dirs, centred):
    """Mean square over the sphere of the relative |h_c| error of the state's offset
    from the truth that the noise does not average away: its bias, and the
    remaining step where the iteration stopped short.

    shared.quadric.Problem.noise_gradient: bias = -H^-1 s2 g, with the noise
    variance s2 from the residuals, rss = 4 s2 mean |A v|^2. Second order:
    nothing beside the spread on a wide cover, ~8x the spread on a 3 % cap at
    1 nT (desktop/bench/honesty.py). centred (field unknown): the part common
    to all directions is a bias of the fitted field, not an error that turns
    with the instrument, and is left out. grads: _sphere_gradients' twelve.
    """
    g, q = pb.noise_gradient(st.s, st.a)
    if not q > num(0.0):
        return num(0.0)
    s2 = rss / (num(4.0) * q)
    # Where the iteration stopped short of the fixed point (a long valley on a
    # small cap), the state is off by the remaining Gauss-Newton step too:
    # st - truth = (st - fixed point) + bias = H^-1 (gradient - s2 g).
    _, grad = system(pb, st, True)
    g = [grad[i] - s2 * g[i] for i in range(9)]
    if dirs:
        g = [sum(p[i] * g[i] for i in range(9)) for p in dirs]
    return _bias_spread(grads, linalg.cho_solve(low, g), dirs, centred, num)


def _bias_spread(grads, bias, dirs, centred, num):
    """The mean square over the directions of the relative |h_c| error the offset `bias` makes
    (gd . bias for each gradient gd), about its mean where centred. shared.linalg_native puts
    linalgc's in its place on a board that has it (the same bits)."""
    errs = []
    for gd in grads:
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


def _variance_sum(low, grads, dirs, num):
    """The sum over the directions of g^T H^-1 g (H = low low^T): the covariance's part of the
    predicted error. shared.linalg_native puts linalgc's in its place on a board that has it."""
    total = num(0.0)
    for g in grads:
        if dirs:
            g = [sum(p[i] * g[i] for i in range(9)) for p in dirs]
        y = linalg.cho_solve(low, g)
        for i in range(len(g)):
            total = total + g[i] * y[i]
    return total


def predicted_error(pb, st, rss, am, a_values, a_vectors, num, h=None, dirs=None, centred=False):
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
        h, g = system(pb, st)
        if dirs:
            h, _ = in_basis(h, g, dirs)
    try:
        low = linalg.cholesky(h, num)
    except ValueError:
        raise FitError(DEGENERATE_COVERAGE, "orientations seen leave the calibration undetermined: rotate about all axes")
    # the twelve directions' gradients, for the covariance here and the bias below (the same
    # lists: ~0.9 M cycles each time they are formed on a Pico in bytecode)
    grads = _sphere_gradients(a_values, a_vectors, am, num)
    var = _variance_sum(low, grads, dirs, num) / num(float(len(_ICO))) * rss / pb.nf
    var = var + _bias_sq(pb, st, rss, low, grads, num, dirs, centred)
    if not var >= num(0.0):
        raise FitError(NON_FINITE, "covariance is not finite")
    return num(math.sqrt(float(var)))
