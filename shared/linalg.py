"""Small dense linear algebra in a chosen number type (no numpy), and the scalar
functions MicroPython's math lacks.

Every routine takes plain lists and does its arithmetic on whatever number
objects it is given: Python floats on the device (32-bit on rp2/esp32/stm32,
30-bit on CircuitPython), numpy.float32 or a rounding class on the desktop to
emulate those. Constants are converted with ``num`` so a mixed expression never
silently widens the precision.
"""

import math


def isfinite(x):
    # inf - inf and nan - nan are nan, which compares unequal to 0; works for
    # float, numpy scalars and number classes alike (math.isfinite does not).
    return x - x == 0


def all_finite(values):
    for x in values:
        if not isfinite(x):
            return False
    return True


def log1p(x):
    # MicroPython's math has no log1p; near convergence x ~ 1e-12 and
    # log(1 + x) would round it away.
    if -1e-4 < x < 1e-4:
        return x - x * x / 2.0 + x * x * x / 3.0
    return math.log(1.0 + x)


def expm1(x):
    if -1e-4 < x < 1e-4:
        return x + x * x / 2.0 + x * x * x / 6.0
    return math.exp(x) - 1.0



def cholesky(a, num):
    """Lower-triangular L with L L^T = a, for a symmetric positive definite a.

    Raises ValueError if a pivot is not positive (a is singular or indefinite).
    """
    n = len(a)
    zero = num(0.0)
    low = [[zero] * n for _ in range(n)]
    for j in range(n):
        s = a[j][j]
        row = low[j]
        for k in range(j):
            s = s - row[k] * row[k]
        if not s > zero or not isfinite(s):
            raise ValueError("matrix not positive definite at pivot %d" % j)
        d = num(math.sqrt(float(s)))
        row[j] = d
        for i in range(j + 1, n):
            s = a[i][j]
            other = low[i]
            for k in range(j):
                s = s - other[k] * row[k]
            other[j] = s / d
    return low


def cho_solve(low, b):
    """Solve L L^T x = b given the Cholesky factor L."""
    n = len(low)
    y = list(b)
    for i in range(n):
        s = y[i]
        row = low[i]
        for k in range(i):
            s = s - row[k] * y[k]
        y[i] = s / row[i]
    for i in range(n - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, n):
            s = s - low[k][i] * y[k]
        y[i] = s / low[i][i]
    return y


def solve_spd(a, b, num):
    """Solve a x = b for symmetric positive definite a, with Jacobi scaling.

    Scaling to a unit diagonal first keeps the float32 factorisation of the
    badly scaled normal matrices (offsets vs. quadric terms) well conditioned.
    """
    n = len(a)
    one = num(1.0)
    d = []
    for i in range(n):
        if not a[i][i] > num(0.0):
            raise ValueError("non-positive diagonal %d" % i)
        d.append(one / num(math.sqrt(float(a[i][i]))))
    scaled = []
    for i in range(n):
        row = a[i]
        di = d[i]
        scaled.append([row[j] * di * d[j] for j in range(n)])
    y = cho_solve(cholesky(scaled, num), [b[i] * d[i] for i in range(n)])
    return [y[i] * d[i] for i in range(n)]


def eigh3(s, num, sweeps=12):
    """Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.

    Returns (values, vectors) with vectors[k] the unit eigenvector of values[k].
    Jacobi is chosen over a closed form (Cardano) because its accuracy does not
    degrade for nearly equal eigenvalues, which is exactly the near-sphere case.
    """
    zero = num(0.0)
    one = num(1.0)
    a = [[s[i][j] for j in range(3)] for i in range(3)]
    v = [[one if i == j else zero for j in range(3)] for i in range(3)]
    big = num(1e6)
    two = num(2.0)
    for _ in range(sweeps):
        off = abs(a[0][1]) + abs(a[0][2]) + abs(a[1][2])
        if off == zero:
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            ap = a[p]
            aq = a[q]
            apq = ap[q]
            if apq == zero:
                continue
            diff = aq[q] - ap[p]
            if abs(diff) > big * abs(apq):
                # Tiny angle: tan = apq / diff; the general formula would
                # overflow theta^2 in single precision.
                t = apq / diff
            else:
                # Stable tangent formula (Golub & Van Loan 8.5.2).
                theta = diff / (two * apq)
                t = one / (abs(theta) + num(math.sqrt(float(theta * theta + one))))
                if theta < zero:
                    t = -t
            c = one / num(math.sqrt(float(t * t + one)))
            sn = t * c
            for row in a:
                akp = row[p]
                akq = row[q]
                row[p] = c * akp - sn * akq
                row[q] = sn * akp + c * akq
            for k in range(3):
                apk = ap[k]
                aqk = aq[k]
                ap[k] = c * apk - sn * aqk
                aq[k] = sn * apk + c * aqk
            ap[q] = zero
            aq[p] = zero
            for row in v:
                vkp = row[p]
                vkq = row[q]
                row[p] = c * vkp - sn * vkq
                row[q] = sn * vkp + c * vkq
    values = [a[0][0], a[1][1], a[2][2]]
    vectors = [[v[0][k], v[1][k], v[2][k]] for k in range(3)]
    return values, vectors


def sym_function(values, vectors, f):
    """V diag(f(values)) V^T for a 3x3 symmetric matrix given by eigh3."""
    fv = [f(x) for x in values]
    return [
        [
            vectors[0][i] * fv[0] * vectors[0][j]
            + vectors[1][i] * fv[1] * vectors[1][j]
            + vectors[2][i] * fv[2] * vectors[2][j]
            for j in range(3)
        ]
        for i in range(3)
    ]


def matvec(m, x):
    x0, x1, x2 = x
    return [row[0] * x0 + row[1] * x1 + row[2] * x2 for row in m]


def det3(m):
    return (
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    )
