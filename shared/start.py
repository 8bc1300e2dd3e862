"""Where the iteration starts: an algebraic quadric fit and a sphere fit, from the float moments.

    for a, f in initial_guesses(pb):   # pb: a shared.quadric.Problem; a, f in its frame
        ...                            # shared.solver keeps the one with the lower exact objective
"""

from shared import linalg
from shared.moments import INDEX, to_float
from shared.quadric import UNIT, W_C, W_EXP, add_exp, sym


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

    means = [None] * len(u)   # each moment converted once: the Gram matrices repeat them

    def mu(exp):
        idx = INDEX[exp]
        x = means[idx]
        if x is None:
            x = means[idx] = num(to_float(u[idx], -e * (exp[0] + exp[1] + exp[2]))) / nf
        return x

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
