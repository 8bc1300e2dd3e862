"""The calibration from the iteration's converged state: M, b and the field, its
diagnostics, and the refusals a finished fit can still meet.

    cal = finish(pb, prior, st, field, num, kr, k_nom, observability, iterations, max_error, h, dirs)

The matrix is assembled so that float rounding acts on the small part of each
entry (|E| ~ 1e-2), not on 1: float32 and 22-bit floats reach the same
calibration as doubles to a few 1e-3 nT.
"""

import math

from shared import linalg
from shared.calibration import Calibration
from shared.codes import DEGENERATE_COVERAGE, NON_FINITE, NOT_ELLIPSOID
from shared.errors import FitError
from shared.moments import bit_length, to_float
from shared.predicted import predicted_error
from shared.prior import Prior
from shared.quadric import FRAC, sym

# Residual rms above this share of the field is not a distorted sphere: the
# noisiest real MEMS log here (QMC5883L) scatters 6 % after the best fit, a
# hyperboloid 19 %.
MAX_MISFIT = 0.1
# The predicted full-sphere error refused (degenerate_coverage) when the caller gives no
# max_error: this share of the field (500 nT at 50,000 nT; the firmware's acceptance is
# tighter, shared/codes.py MAX_PREDICTED_NT).
MAX_ERROR_SHARE = 0.01


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


def finish(pb, pr, st, field, num, kr, k_nom, observability, iterations, max_error, h=None, dirs=None):
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
        log_det += linalg.log1p(float(l))
    # t' = tr(K^-1 A_raw K^-1)/3 with A_raw = A_frame / 4^e (nominal-unit quadric scale).
    kn = [num(k) for k in k_nom]
    t_raw = (st.a[0] / (kn[0] * kn[0]) + st.a[1] / (kn[1] * kn[1]) + st.a[2] / (kn[2] * kn[2])) / num(3.0)
    t_raw = t_raw / num(math.ldexp(1.0, 2 * pb.e))
    # det(s G) = 1 fixes the gain when the field is unknown: s = det(I+E)^(-1/6) = 1 + sigma.
    sigma = linalg.expm1(-log_det / 6.0)
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
    predicted = predicted_error(pb, st, rss, am, a_values, a_vectors, num, h, dirs, field is None) * field_out

    flat = [v for row in matrix for v in row] + offset + [field_out, rms, predicted]
    if not linalg.all_finite(flat):
        raise FitError(NON_FINITE, "calibration is not finite")
    if float(rms) > MAX_MISFIT * float(field_out):
        raise FitError(NOT_ELLIPSOID, "samples do not lie on an ellipsoid: residual %.3g nT rms is %.0f %% of the field" % (float(rms), 100.0 * float(rms) / float(field_out)))
    limit = max_error if max_error is not None else MAX_ERROR_SHARE * float(field_out)
    if float(predicted) > limit:
        raise FitError(DEGENERATE_COVERAGE, "predicted full-sphere error %.3g nT exceeds %.3g nT: rotate through more orientations" % (float(predicted), limit))
    diagnostics = {
        "n": pb.n,
        "rms": float(rms),
        "observability": observability,
        "predicted_error": float(predicted),
        "iterations": iterations,
        "radius": float(radius),
    }
    return Calibration([[float(v) for v in row] for row in matrix], [float(v) for v in offset], float(field_out), diagnostics)
