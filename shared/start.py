"""Where the iteration starts: an algebraic quadric fit and a sphere fit, from the float moments.

    for a, f in initial_guesses(pb):   # pb: a shared.quadric.Problem; a, f in its frame
        ...                            # shared.solver keeps the one with the lower exact objective
"""

from shared import linalg
from shared.moments import DEGREE, INDEX, to_float
from shared.quadric import UNIT, W_C, W_EXP, add_exp, sym

try:
    from micropython import const
except ImportError:     # CPython: the value itself
    def const(x):
        return x

# The moments the Gram matrices read, as storage indices worked out once (a board spends its cycles
# on the calls and tuples that would find them), in one bytes object (each object more is a board's
# heap while a session runs; const names are not even in the module's dict on MicroPython): the
# algebraic fit's features (w(v), v) two by two, then their weights W_C[p] W_C[q]; the features
# alone and their weights W_C[p]; the sphere fit's v_i v_j, v_i |v|^2 (i by i), v_i and |v|^2's
# three; last, every index named before (_MOMENTS: the sphere's are among the algebraic ones).
_GRAM_W = const(81)
_RHS = const(162)
_RHS_W = const(171)
_SPHERE = const(180)
_CUBES = const(189)
_LINEAR = const(198)
_SQUARE = const(201)
_MOMENTS = const(204)
_FEATS = [(W_EXP[m], W_C[m]) for m in range(6)] + [(UNIT[i], 1) for i in range(3)]
_SQUARES = ((2, 0, 0), (0, 2, 0), (0, 0, 2))
_TABLE = ([INDEX[add_exp(fp[0], fq[0])] for fp in _FEATS for fq in _FEATS] + [fp[1] * fq[1] for fp in _FEATS for fq in _FEATS]
          + [INDEX[fp[0]] for fp in _FEATS] + [fp[1] for fp in _FEATS]
          + [INDEX[add_exp(UNIT[i], UNIT[j])] for i in range(3) for j in range(3)]
          + [INDEX[add_exp(UNIT[i], sq)] for i in range(3) for sq in _SQUARES]
          + [INDEX[x] for x in UNIT] + [INDEX[x] for x in _SQUARES])
_TABLE = bytes(_TABLE + sorted(set(_TABLE[:_GRAM_W]) | set(_TABLE[_RHS:_RHS_W])))
del _FEATS, _SQUARES    # (the code above runs once, at import; only the bytes object stays)


def initial_guesses(pb):
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

    t = _TABLE
    mu = [None] * len(u)   # each moment about C converted once: the Gram matrices repeat them
    for k in range(_MOMENTS, len(t)):
        idx = t[k]
        mu[idx] = num(to_float(u[idx], -e * DEGREE[idx])) / nf

    guesses = []
    weight = [None, num(1.0), num(2.0), None, num(4.0)]     # num(float(W_C[p] W_C[q]))
    gram = [[mu[t[k]] * weight[t[_GRAM_W + k]] for k in range(9 * p, 9 * p + 9)] for p in range(9)]
    rhs = [mu[t[_RHS + p]] * weight[t[_RHS_W + p]] for p in range(9)]
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
    gram = [[mu[t[_SPHERE + 3 * i + j]] for j in range(3)] + [mu[t[_LINEAR + i]]] for i in range(3)]
    gram.append([mu[t[_LINEAR + j]] for j in range(3)] + [one])
    rhs = [-(mu[t[_CUBES + 3 * i]] + mu[t[_CUBES + 3 * i + 1]] + mu[t[_CUBES + 3 * i + 2]]) for i in range(3)]
    rhs.append(-(mu[t[_SQUARE]] + mu[t[_SQUARE + 1]] + mu[t[_SQUARE + 2]]))
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
