"""Where the iteration starts: an algebraic quadric fit and a sphere fit, from the float moments.

    for a, f in initial_guesses(pb):   # pb: a shared.quadric.Problem; a, f in its frame
        ...                            # shared.solver keeps the one with the lower exact objective
"""

from shared import linalg
from shared.moments import DEGREE, INDEX, to_float
from shared.quadric import UNIT, W_C, W_EXP, add_exp, sym

# The moments the Gram matrices read, as storage indices worked out once (a board spends its cycles
# on the calls and tuples that would find them): the algebraic fit's features (w(v), v) two by two
# with their weights W_C[p] W_C[q], the features alone with W_C[p]; the sphere fit's v_i v_j, v_i,
# v_i |v|^2 and |v|^2. _MOMENTS: every index they name (the sphere's are among the algebraic ones).
_FEATS = [(W_EXP[m], W_C[m]) for m in range(6)] + [(UNIT[i], 1) for i in range(3)]
_GRAM = bytes([INDEX[add_exp(fp[0], fq[0])] for fp in _FEATS for fq in _FEATS])
_GRAM_W = bytes([fp[1] * fq[1] for fp in _FEATS for fq in _FEATS])
_RHS = bytes([INDEX[fp[0]] for fp in _FEATS])
_RHS_W = bytes([fp[1] for fp in _FEATS])
_SQUARES = ((2, 0, 0), (0, 2, 0), (0, 0, 2))
_SPHERE = bytes([INDEX[add_exp(UNIT[i], UNIT[j])] for i in range(3) for j in range(3)])
_CUBES = bytes([INDEX[add_exp(UNIT[i], sq)] for i in range(3) for sq in _SQUARES])
_LINEAR = bytes([INDEX[x] for x in UNIT])
_SQUARE = bytes([INDEX[x] for x in _SQUARES])
_MOMENTS = bytes(sorted(set(_GRAM) | set(_RHS)))
del _FEATS, _SQUARES


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

    mu = [None] * len(u)   # each moment about C converted once: the Gram matrices repeat them
    for idx in _MOMENTS:
        mu[idx] = num(to_float(u[idx], -e * DEGREE[idx])) / nf

    guesses = []
    weight = [None, num(1.0), num(2.0), None, num(4.0)]     # num(float(W_C[p] W_C[q]))
    gram = [[mu[_GRAM[k]] * weight[_GRAM_W[k]] for k in range(9 * p, 9 * p + 9)] for p in range(9)]
    rhs = [mu[_RHS[p]] * weight[_RHS_W[p]] for p in range(9)]
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
    gram = [[mu[_SPHERE[3 * i + j]] for j in range(3)] + [mu[_LINEAR[i]]] for i in range(3)]
    gram.append([mu[_LINEAR[j]] for j in range(3)] + [one])
    rhs = [-(mu[_CUBES[3 * i]] + mu[_CUBES[3 * i + 1]] + mu[_CUBES[3 * i + 2]]) for i in range(3)]
    rhs.append(-(mu[_SQUARE[0]] + mu[_SQUARE[1]] + mu[_SQUARE[2]]))
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
