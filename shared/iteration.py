"""The Levenberg-Marquardt iteration on objective (2) of shared/solver.py, in fixed point.

    st = State(pb, prior, a_int, f_int)    # the exact RSS and gradient terms at integer parameters
    st, h, iterations, rejected = iterate(pb, prior, st, num, max_iter)
    st.worse_than(other, n)                # objective (2), compared exactly where it matters
    log_ratio(st.rss, other.rss)           # log of the ratio of two exact RSS integers

The parameters are integers with FRAC fractional bits (quantise); the data
gradient and the RSS are exact, only the step direction is computed in the
number type num (shared/solver.py says why that is enough).
"""

import math

from shared import linalg
from shared.codes import NON_FINITE
from shared.errors import FitError
from shared.moments import bit_length, to_float
from shared.quadric import FRAC, sym

MAX_ITER = 60        # Levenberg-Marquardt iterations at most: the default of every solve
# A solve of at most this many iterations is a provisional estimate (a device's, every few
# seconds while collecting): its error estimate may use a normal matrix one step old, and a
# quick re-calibration skips its shape test (shared/quick.py).
PROVISIONAL_ITER = 2


def quantise(x):
    return int(round(math.ldexp(float(x), FRAC)))


class State:
    def __init__(self, pb, prior, a_int, f_int, near=None):
        """near: a state nearby (the one a step starts from): the sums re-centred from its
        sums, the same integers as from the problem's (Problem.sums_at)."""
        self.a_int = a_int
        self.f_int = f_int
        self.s = pb.sums_at(f_int, None if near is None else (near.s, near.f_int))
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
    return linalg.log1p(rel) if -1e-4 < rel < 1e-4 else math.log(a / b)


def system(pb, st, gradient_only=False):
    """Normal matrix (None if gradient_only) and gradient of (2) at st."""
    if gradient_only:
        h = None
        g = pb.gradient(st.ga, st.t, sym(st.a))
    else:
        h, g = pb.normal_equations(st.s, st.ga, st.t, st.a)
    if st.rho:
        lam = pb.value(st.rss, -6 * FRAC) / (pb.nf * pb.nf)  # (RSS/N)/N
        add_prior(h, g, st.rho, st.jac, lam, pb.num(0.0))
    return h, g


def add_prior(h, g, rho, jac, lam, zero):
    """The prior's terms of (2) added to H (None: the gradient only) and g in place, lam = (RSS/N)/N:
    g += lam J^T rho, H += lam J^T J. shared.linalg_native puts linalgc's in its place on a board
    that has it (the same bits)."""
    for r, row in zip(rho, jac):
        for i in range(9):
            ri = row[i]
            if ri == zero:
                continue
            lr = lam * ri      # the products as written lam * row[i] * row[k]: (lam row[i]) row[k]
            g[i] = g[i] + lr * r
            if h is not None:
                hi = h[i]
                for k in range(9):
                    hi[k] = hi[k] + lr * row[k]


def in_basis(h, g, basis):
    """H and g of (2) in the coordinates of basis (columns p_k: dp = sum c_k p_k)."""
    hp = [[sum(h[i][j] * p[j] for j in range(9)) for i in range(9)] for p in basis]
    hr = [[sum(p[i] * q[i] for i in range(9)) for q in hp] for p in basis]
    gr = [sum(p[i] * g[i] for i in range(9)) for p in basis]
    return hr, gr


def iterate(pb, pr, st, num, max_iter, basis=None, between=None):
    """Levenberg-Marquardt on objective (2) from the state st.

    basis: None to move all nine parameters, or an object whose
    directions(st) are the directions they may move in (lists of 9 floats)
    and apply(st, step) turns a step in those coordinates into the integer
    changes (da, df) of the state. Returns (state, normal matrix or None, iterations,
    rejected steps); the normal matrix is the last one formed, returned where
    it is valid at the state (see below), in the basis' coordinates. between: None, or called
    before each iteration after the first (a device drains its DRDY ring: device/session.py).
    """
    n = pb.n
    mu = 1e-3
    iterations = 0
    rejected = 0       # Levenberg-Marquardt steps refused for raising the objective
    h = None
    moved = small = False
    for iterations in range(1, max_iter + 1):
        if between is not None and iterations > 1:
            between()
        h, g = system(pb, st)
        if not linalg.all_finite(g):
            raise FitError(NON_FINITE, "gradient is not finite")
        dirs = basis.directions(st) if basis else None
        if dirs:
            h, g = in_basis(h, g, dirs)
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
            if not linalg.all_finite(step):
                raise FitError(NON_FINITE, "step is not finite")
            if dirs:
                da, df = basis.apply(st, step)
            else:
                da = [quantise(x) for x in step[:6]]
                df = [quantise(x) for x in step[6:]]
            if not any(da) and not any(df):
                break
            biggest = max(abs(float(x)) for x in step)
            cand = None   # a refused candidate is garbage before the next is built (a board's heap)
            cand = State(pb, pr, [st.a_int[i] + da[i] for i in range(6)], [st.f_int[i] + df[i] for i in range(3)], st)
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
    # (max_iter <= PROVISIONAL_ITER: a device's provisional estimate) whose result is an estimate anyway
    if moved and not small and max_iter > PROVISIONAL_ITER:
        h = None
    return st, h, iterations, rejected
