"""The fit's exact algebra: residuals, gradient and normal matrix from power sums.

Model (paper eq. 2): h_c = M (h - b), |h_c| = R for every orientation. With
A = M^T M / R^2 each sample gives the residual

    r = v^T A v - 1,   v = (h - b) / 2^e            (1)

(|M(h-b)|^2 - R^2 normalised by R^2; 2^e is a power-of-two frame scale). For
any A and b, sum r dr/dp and the normal matrix are polynomials of degree <= 4
in v, so they follow from the power sums re-centred on b (shared.moments).

The parameters are held as fixed-point integers (FRAC fractional bits), so the
data gradient sum w r, sum v r and the residual sum of squares are computed
*exactly* in integers; only the normal matrix is formed in the chosen number
type (shared.solver explains why that is enough).
"""

from shared.moments import COUNT, DEGREE, INDEX, ORDER, bit_length, mean_centre, recentred, scaled, shifted, to_float

FRAC = 40  # fractional bits of the fixed-point parameters (relative 1e-12)

# The quadric terms w(v) with w.a = v^T A v, a = (A11, A22, A33, A12, A13, A23).
W_EXP = ((2, 0, 0), (0, 2, 0), (0, 0, 2), (1, 1, 0), (1, 0, 1), (0, 1, 1))
W_C = (1, 1, 1, 2, 2, 2)
UNIT = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
PAIR = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def add_exp(e1, e2):
    return (e1[0] + e2[0], e1[1] + e2[1], e1[2] + e2[2])


_IDX4 = [[INDEX[add_exp(W_EXP[m], W_EXP[n])] for n in range(6)] for m in range(6)]
_IDX3 = [[INDEX[add_exp(UNIT[i], W_EXP[n])] for n in range(6)] for i in range(3)]
_IDX2 = [INDEX[e] for e in W_EXP]
_IDX1 = [INDEX[e] for e in UNIT]
_IDX2M = [[INDEX[add_exp(UNIT[i], UNIT[j])] for j in range(3)] for i in range(3)]
# the storage indices of the power sums the normal matrix uses: degrees 2 to 4
# (one bytes object: a tuple of pairs is ~600 B more of a board's heap while a session runs)
_MEANS = bytes([INDEX[e] for e in ORDER if 2 <= e[0] + e[1] + e[2] <= 4])

def sym(a):
    return [[a[0], a[3], a[4]], [a[3], a[1], a[5]], [a[4], a[5], a[2]]]


def frame_means(s, indices, num):
    """The power sums s at `indices` as floats in the frame, each over 2^(FRAC degree) (times nf their
    means), in a list by storage index (None elsewhere). shared.linalg_native puts linalgc's in its
    place on a board that has it (from the sums' words: the same bits)."""
    mean = [None] * COUNT
    for idx in indices:
        mean[idx] = num(to_float(s[idx], -DEGREE[idx] * FRAC))
    return mean


def normal_matrix(mean, am, nf, num):
    """Problem.normal_equations' float part: the per-sample normal matrix H (9x9) from the power
    sums of degree 2..4 as floats in the frame (`mean`, by storage index; over nf their means) and
    A (3x3), each entry formed by the same operations as if written out. shared.linalg_native puts
    linalgc's in its place on a board that has it (the same bits)."""
    two = num(2.0)
    weights = [num(float(c)) for c in (1, 2, 4)]
    m4 = [[None] * 6 for _ in range(6)]
    for m in range(6):
        row4 = _IDX4[m]
        wm = W_C[m]
        out = m4[m]
        for k in range(m, 6):
            x = mean[row4[k]] * weights[(wm * W_C[k]) >> 1] / nf
            out[k] = x
            m4[k][m] = x
    m3 = [[mean[_IDX3[i][k]] * weights[W_C[k] >> 1] / nf for k in range(6)] for i in range(3)]
    m2 = [[None] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i, 3):
            x = mean[_IDX2M[i][j]] / nf
            m2[i][j] = x
            m2[j][i] = x
    h = [m4[m] + [None] * 3 for m in range(6)] + [[None] * 9 for _ in range(3)]
    for m in range(6):
        for i in range(3):
            # d r / d f_i = -2 (A v)_i
            x = -two * (am[i][0] * m3[0][m] + am[i][1] * m3[1][m] + am[i][2] * m3[2][m])
            h[m][6 + i] = x
            h[6 + i][m] = x
    am2 = [[am[i][0] * m2[0][j] + am[i][1] * m2[1][j] + am[i][2] * m2[2][j] for j in range(3)] for i in range(3)]
    four = num(4.0)
    for i in range(3):
        for k in range(3):
            h[6 + i][6 + k] = four * (am2[i][0] * am[0][k] + am2[i][1] * am[1][k] + am2[i][2] * am[2][k])
    return h


class Problem:
    """The fit in the frame v = (h - C) / 2^e, parameters as fixed-point ints."""

    def __init__(self, sums, num):
        self.num = num
        self.n = sums[0]
        self.nf = num(float(self.n))
        self.centre = mean_centre(sums)
        self.u = shifted(sums, 1, self.centre)  # exact sums of h - C
        u = self.u
        n = self.n
        # n^2 * covariance, exact.
        cov = [[n * u[_IDX2M[i][j]] - u[_IDX1[i]] * u[_IDX1[j]] for j in range(3)] for i in range(3)]
        trace = (cov[0][0] + cov[1][1] + cov[2][2]) // (n * n)
        # Frame scale 2^e ~ rms spread: every moment in the frame is O(1).
        self.e = (bit_length(trace) + 1) // 2
        if self.e > FRAC:
            raise ValueError("input values too large for the fixed-point frame")
        self.shift = 1 << (FRAC - self.e)
        self.scaled = scaled(u, self.shift)   # exact sums of V = 2^FRAC v for the centre C
        self.cov = [[num(to_float(c, -2 * self.e)) / (self.nf * self.nf) for c in row] for row in cov]

    # -- exact part ----------------------------------------------------------
    def sums_at(self, f_int, near=None):
        """Exact sums of V = 2^FRAC v for the centre b = C + f_int 2^(e-FRAC); from the sums
        `near` at the centre f_near, given as (sums, f_near), where one is at hand: the
        same integers, from smaller products (the iteration's steps are small)."""
        if near is None:
            return recentred(self.scaled, f_int)
        sums, f_near = near
        return recentred(sums, [f_int[0] - f_near[0], f_int[1] - f_near[1], f_int[2] - f_near[2]])

    def exact(self, s, a_int):
        """(g_A, T, RSS) as exact ints: 2^5F sum w r, 2^4F sum v r, 2^6F sum r^2.

        With ac_k = W_C[k] a_k (w.a = sum_k ac_k v^(W_EXP k)):
        g_A[m] = W_C[m] (sum_k ac_k S[W_EXP m + W_EXP k] - 2^3F S[W_EXP m]),
        T[i] = sum_k ac_k S[e_i + W_EXP k] - 2^3F S[e_i],
        RSS = 2^6F n - 2^3F sum_m ac_m S[W_EXP m] + sum_m a_m g_A[m].
        """
        f3 = 3 * FRAC
        ac = [a_int[0], a_int[1], a_int[2], a_int[3] << 1, a_int[4] << 1, a_int[5] << 1]
        a0, a1, a2, a3, a4, a5 = ac
        ga = []
        for m in range(6):
            r = _IDX4[m]
            acc = (a0 * s[r[0]] + a1 * s[r[1]] + a2 * s[r[2]] + a3 * s[r[3]] + a4 * s[r[4]] + a5 * s[r[5]]
                   - (s[_IDX2[m]] << f3))
            ga.append(acc if m < 3 else acc << 1)
        t = []
        for i in range(3):
            r = _IDX3[i]
            t.append(a0 * s[r[0]] + a1 * s[r[1]] + a2 * s[r[2]] + a3 * s[r[3]] + a4 * s[r[4]] + a5 * s[r[5]]
                     - (s[_IDX1[i]] << f3))
        r = _IDX2
        lin = a0 * s[r[0]] + a1 * s[r[1]] + a2 * s[r[2]] + a3 * s[r[3]] + a4 * s[r[4]] + a5 * s[r[5]]
        rss = (self.n << (2 * f3)) - (lin << f3)
        for m in range(6):
            rss += a_int[m] * ga[m]
        return ga, t, rss

    # -- float part ----------------------------------------------------------
    def value(self, x, exponent):
        return self.num(to_float(x, exponent))

    def normal_equations(self, s, ga, t, a):
        """Per-sample normal matrix H (9x9) and gradient g of (1) at the state (a: its quadric's
        floats). Each power sum of degree 2..4 the blocks use is converted to a float once (the
        symmetric blocks share them), each entry formed by the same operations as if written out."""
        am = sym(a)
        return normal_matrix(frame_means(s, _MEANS, self.num), am, self.nf, self.num), self.gradient(ga, t, am)

    def gradient(self, ga, t, am):
        """Per-sample gradient g of (1) from the exact (g_A, T) and A (3x3)."""
        nf = self.nf
        two = self.num(2.0)
        tv = [self.value(x, -4 * FRAC) / nf for x in t]
        g = [self.value(x, -5 * FRAC) / nf for x in ga]
        for i in range(3):
            g.append(-two * (am[i][0] * tv[0] + am[i][1] * tv[1] + am[i][2] * tv[2]))
        return g



    def noise_gradient(self, s, a):
        """(g, q): half the gradient of the noise's expected share of mean r^2,
        per unit of noise variance in the frame, and q = mean |A v|^2.

        With v = v0 + n (white, variance s2 per axis), E r^2 = r0^2 + s2 (4
        |A v|^2 + 2 tr(A) r) + O(s2^2): minimising sum r^2 leans towards
        smaller |A v|, a bias of -H^-1 s2 g (second order in the noise, and on
        a small cap, where H is nearly singular, far above the spread:
        shared.predicted adds it).
        """
        num = self.num
        nf = self.nf
        am = sym(a)
        m2 = [[self.value(s[_IDX2M[i][j]], -2 * FRAC) / nf for j in range(3)] for i in range(3)]
        m1 = [self.value(s[_IDX1[i]], -FRAC) / nf for i in range(3)]
        a_s = [[am[i][0] * m2[0][j] + am[i][1] * m2[1][j] + am[i][2] * m2[2][j] for j in range(3)] for i in range(3)]
        a2 = [[am[i][0] * am[0][j] + am[i][1] * am[1][j] + am[i][2] * am[2][j] for j in range(3)] for i in range(3)]
        tr = am[0][0] + am[1][1] + am[2][2]
        mean_r = num(-1.0)
        q = num(0.0)
        for i in range(3):
            for j in range(3):
                mean_r = mean_r + am[i][j] * m2[i][j]
                q = q + a2[i][j] * m2[i][j]
        g = []
        for m in range(6):
            i, j = PAIR[m]
            c = num(float(W_C[m]))
            # 2 d tr(A^2 S)/da_m + d (tr(A) mean r)/da_m
            g.append(num(2.0) * c * (a_s[i][j] + a_s[j][i]) + (mean_r if m < 3 else num(0.0)) + tr * c * m2[i][j])
        for i in range(3):
            a2m = a2[i][0] * m1[0] + a2[i][1] * m1[1] + a2[i][2] * m1[2]
            am1 = am[i][0] * m1[0] + am[i][1] * m1[1] + am[i][2] * m1[2]
            g.append(num(-4.0) * a2m - num(2.0) * tr * am1)
        return g, q
