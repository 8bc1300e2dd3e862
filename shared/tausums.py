"""The fit's power sums at any de-lag time constant, exactly, from five accumulators.

    from shared.tausums import TauSums, lagrange_sums, minimise
    ts = TauSums()                          # the four nodes besides the fit's own
    ts.add(x, y, z, ex, ey, ez)             # a sample de-lagged at the configured tau, and its step
    ts.remove(x, y, z, ex, ey, ez)          # exact inverse (the gates' back-off)
    sums = lagrange_sums(fit.sums(), ts.sums(), p, q)   # the sums of q x + p e: the samples at t = p / q
    t, t_sigma, rms = minimise(rms_at, n, lo, hi)       # the t of least residual and its uncertainty

Why: a sample de-lagged at tau is x(tau) = y + tau y' (shared/delag.py), affine in tau. The
firmware de-lags with the configured tau (x, the sample the gates and the fit take) and,
for the estimate, also forms the step e = round(dnum (8 d1 - d2) / 2**shift), the de-lag
term of a tau step dtau (Delag.set_taus(step_us=...)). The sample x + t e is then exactly
affine in t (one rounding of x, one of e: 0.5 + |t| 0.5 sum units, noise far below the
sensor's), so each of the 35 power sums of degree d <= 4 is a polynomial of degree d in t,
with integer coefficients. Five exact accumulators at the nodes t = -2 .. 2 (the fit's own at
t = 0, the four here) determine it everywhere: at a rational t = p / q, Lagrange's formula

    24 q^4 S(p / q) = sum_j c_j N_j S_j,   N_j = prod_(k != j) (p - t_k q),   c = (1, -4, 6, -4, 1)

(24 / c_j = prod_(k != j) (t_j - t_k)) is an identity in integers, and the sums of the
integer samples q x + p e are S_d(p / q) q^d, an exact division of that by 24 q^(4 - d). So the
fit can be solved at any tau, exactly and the same on every interpreter, and the tau that
leaves the least residual chosen (minimise): a lag delta left reads |B| long or short by
B (delta w)^2 / 2, which the fit cannot absorb where the turn rate w varies.

Cost: four more EllipsoidFit.add per accepted sample, four more sets of 35 sums, and the
solves of the search at the end (session.py).
"""

from shared.fit import EllipsoidFit
from shared.moments import COUNT, ORDER

NODES = (-2, -1, 1, 2)          # t of the four accumulators here (the fit's own is t = 0)
_ALL = (-2, -1, 0, 1, 2)
_C = (1, -4, 6, -4, 1)          # 24 / prod_(k != j) (t_j - t_k)
_DEG = bytes([e[0] + e[1] + e[2] for e in ORDER])


class TauSums:
    def __init__(self):
        self.fits = [EllipsoidFit() for _ in NODES]

    def add(self, x, y, z, ex, ey, ez, _out=False):
        t = 0
        for f in self.fits:
            j = NODES[t]
            f.add(x + j * ex, y + j * ey, z + j * ez, _out)
            t += 1

    def remove(self, x, y, z, ex, ey, ez):
        if self.fits[0].n < 1:
            raise ValueError("remove from an empty fit")
        self.add(x, y, z, ex, ey, ez, True)

    def sums(self):
        """The four nodes' 35 power sums each (shared.moments.ORDER), t = -2, -1, 1, 2."""
        return [f.sums() for f in self.fits]


def lagrange_sums(centre, nodes, p, q):
    """The 35 power sums of q x + p e (ints), from the sums of x (centre, t = 0) and of
    x + t e at t = -2, -1, 1, 2 (nodes): exact for any integers p and q > 0."""
    if q < 1:
        raise ValueError("q must be a positive integer")
    rows = [nodes[0], nodes[1], centre, nodes[2], nodes[3]]
    w = []
    for j in range(5):
        n = _C[j]
        for k in range(5):
            if k != j:
                n *= p - _ALL[k] * q
        w.append(n)
    qp = [24, 24 * q, 24 * q * q, 24 * q * q * q, 24 * q * q * q * q]   # 24 q^(4 - d) by 4 - d
    out = [0] * COUNT
    for i in range(COUNT):
        s = w[0] * rows[0][i] + w[1] * rows[1][i] + w[2] * rows[2][i] + w[3] * rows[3][i] + w[4] * rows[4][i]
        out[i] = s // qp[4 - _DEG[i]]
    return out


def _parabola_min(a, b, c):
    """The vertex t of the parabola through the points a, b, c ((t, v) each; b the lowest),
    kept within a[0] .. c[0]; b's t if they are collinear."""
    (t0, v0), (t1, v1), (t2, v2) = a, b, c
    den = (t1 - t0) * (v1 - v2) - (t1 - t2) * (v1 - v0)
    if not den:
        return t1
    t = t1 - 0.5 * ((t1 - t0) ** 2 * (v1 - v2) - (t1 - t2) ** 2 * (v1 - v0)) / den
    return min(max(t, t0), t2)


def minimise(rms_at, n, lo=-5, hi=5, q=64, refine=2):
    """(t, t_sigma, rms) at the least rms_at(p, q) over t = p / q in lo .. hi (nodes' units).

    rms_at(p, q): the fit's residual rms for the samples at t = p / q, or None where it
    cannot be solved. Searched on the whole nodes first (-2 .. 2, widened while the least is at
    an end, up to lo / hi), then `refine` parabola steps on the q grid. t_sigma, from the
    residual sum of squares n rms^2 rising by rms^2 (one parameter, one unit of chi-square),
    along the curve v + b d^2 + c d^4 fitted to the points nearest the least (the lag left,
    delta, raises it by ~delta^4 where the noise of the de-lag term, ~delta^2, does not), and
    the last parabola step's move in quadrature (how far the search still went); None when the
    curve does not rise (turned too slowly to see the lag). t None: nothing solved.
    """
    pts = {}

    def at(p):
        if p not in pts:
            r = rms_at(p, q)
            pts[p] = None if r is None else r * r
        return pts[p]

    for t in range(-2, 3):
        at(t * q)
    best = _least(pts)
    if best is None:
        return None, None, None
    while best == min(pts) and best > lo * q or best == max(pts) and best < hi * q:
        at(best - q if best == min(pts) else best + q)
        new = _least(pts)
        if new == best:
            break
        best = new
    moved = 0
    for _ in range(refine):
        near = sorted(p for p in pts if pts[p] is not None)
        i = near.index(best)
        if i == 0 or i == len(near) - 1:
            break
        a, c = near[i - 1], near[i + 1]
        p = round(_parabola_min((a, pts[a]), (best, pts[best]), (c, pts[c])))
        if p in pts:
            moved = 0
            break
        moved = p - best
        at(p)
        best = _least(pts)
    v = pts[best]
    sigma = _sigma(pts, best, v, n, q)
    if sigma is not None:
        # the search's own: its last parabola step's move (a flat, quartic bottom converges slowly)
        sigma = (sigma * sigma + (moved / q) ** 2) ** 0.5
    return best / q, sigma, v ** 0.5


def _least(pts):
    best = None
    for p in pts:
        if pts[p] is not None and (best is None or pts[p] < pts[best]):
            best = p
    return best


def _sigma(pts, best, v, n, q):
    """The t step where v + b d^2 + c d^4 (least squares over the points within 2 nodes of
    best) reaches v (1 + 1 / n); None when b and c are not both >= 0 with one > 0."""
    # normal equations of (b, c) for the rise r = v_p - v against d^2, d^4
    s22 = s24 = s44 = r2 = r4 = 0.0
    for p in pts:
        if pts[p] is None or p == best or abs(p - best) > 2 * q:
            continue
        d2 = ((p - best) / q) ** 2
        r = pts[p] - v
        s22 += d2 * d2
        s24 += d2 * d2 * d2
        s44 += d2 * d2 * d2 * d2
        r2 += r * d2
        r4 += r * d2 * d2
    det = s22 * s44 - s24 * s24
    if not s22 > 0.0:
        return None
    if det > 1e-12 * s22 * s44:
        b = (r2 * s44 - r4 * s24) / det
        c = (r4 * s22 - r2 * s24) / det
    else:
        b, c = r2 / s22, 0.0
    if b < 0.0 or c < 0.0:
        b, c = max(b, 0.0), max(c, 0.0)
    rise = v / n
    if c > 0.0:
        # c u^2 + b u = rise, u = d^2
        u = (-b + (b * b + 4.0 * c * rise) ** 0.5) / (2.0 * c)
    elif b > 0.0:
        u = rise / b
    else:
        return None
    return u ** 0.5
