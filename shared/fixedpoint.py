"""The survey's correction in integers: h_c = M (s / n - b) and |h_c|, the same digits on
every float width (double, float32, the 30-bit floats of CircuitPython).

    from shared.fixedpoint import ExactCorrection
    ex = ExactCorrection(cal, 2)          # inputs are sums of 2 codes (the boxcar's window)
    f = ex.magnitude(sx, sy, sz)          # |h_c| in 1/256 milli-nT (an int)
    mx, my, mz = ex.correct(sx, sy, sz)   # h_c in milli-nT (a tuple of ints, rounded)

Why: a 30-bit float holds 22 bits, so 48,000 nT to 0.016 nT; even stored in it, M and b move
|h_c| by ~0.01 nT. Here M and b enter as the exact binary values of the record
(Calibration.exact_pairs: each number m 2**e with integers m, e), every product is an
integer, and |h_c| is an integer square root, so the only errors are the roundings below,
whatever the interpreter's float:
- coefficients M / n in 2**-36 milli-nT per input unit: 0.5 of that per unit of input,
  at most 2**29 units a sum (2**23 codes x 64) over three axes: <= 2.4e-5 nT per axis;
- h_c floored to 1/256 milli-nT (3.9e-6 nT per axis) and its norm floored to the same unit.
Everything is Python's integers; products of 24-bit codes and 40-bit coefficients are big
integers on a 32-bit port (a heap allocation each): 9 products and about 25 other operations
a sample, cheaper on a float32 board than the boxed floats they replace.

Where the board has the native module fitsums (device/native/fitsums.c and hc.h, MicroPython
only), magnitude and correct run in its machine words for corrections whose numbers fit them
(decided once, in __init__; `path` says "native" or "python"), the same integers; the
pure-Python methods below stay the reference, CircuitPython's and CPython's path, and the
fall-back for a sum or an h_c past the words. device/survey.py's per-sample path calls
fitsums.survey with `_native` itself (|h_c| summed into the block's words, no int object made).

Temperature drift (Calibration.at_temperature's model) is applied to the exact values: the
gain factors 1 / (1 + g tau) as exact fractions of the interpreter's product g tau, the
offsets b + o tau likewise; only g tau and o tau themselves carry the float's rounding
(2**-22 relative on 30-bit floats: 5e-11 of the field at 20 ppm/C over 10 C).
"""

import math
from array import array

try:
    # |h_c| in C where deploy installed the board's fitsums.mpy (MicroPython; not CPython or
    # CircuitPython, which load no MicroPython .mpy): ImportError also for a fitsums without it
    from fitsums import magnitude as _native_magnitude
except (ImportError, ValueError):    # ValueError: a .mpy of another architecture or version
    _native_magnitude = None
try:
    # and the block's h_c (a fitsums from before it: the pure-Python correct)
    from fitsums import correct as _native_correct
except (ImportError, ValueError):
    _native_correct = None
NATIVE = _native_magnitude is not None   # |h_c| in C can run here (a correction's `path` says if it does)

FRACTION_BITS = 8        # |h_c| and its axes carry 8 bits below the milli-nT
_COEF_BITS = 36          # the coefficients' bits below the milli-nT (precision above)
_TWO53 = 9007199254740992.0   # 2**53: a float's significand times it is an integer on every width
# what fitsums.magnitude's words take (fitsums.c): |w| < 2**31, |c|, |k| < 2**63 (0 < d < 32)
_NATIVE_LIMITS = (1 << 31,) * 3 + (1 << 63,) * 12


def float_pair(x):
    """(m, e) with x == m * 2**e exactly, m an int with no trailing zero bits (0 -> (0, 0))."""
    mant, e = math.frexp(x)
    m = int(mant * _TWO53)   # exact: a scaling by a power of two, the result integral
    if m == 0:
        return (0, 0)
    e -= 53
    while not m & 0xFFFF:
        m >>= 16
        e += 16
    while not m & 1:
        m >>= 1
        e += 1
    return (m, e)


def _round_div(num, den):
    """num / den rounded to the nearest integer (halves up); den > 0."""
    return (2 * num + den) // (2 * den)


def fraction(p, num=1, den=1, shift=0):
    """The pair p times num / den * 2**shift as an exact fraction (numerator, denominator > 0)."""
    k = p[1] + shift
    if k >= 0:
        return (p[0] * num) << k, den
    return p[0] * num, den << -k


def native_numbers(flat):
    """ExactCorrection._flat as fitsums.magnitude takes it: each number as four 16-bit limbs of
    its 64-bit two's complement (small ints on every port), least significant first; None
    without the native module or where a number does not fit its words."""
    if _native_magnitude is None or not 0 < flat[15] < 32:
        return None
    for v, m in zip(flat, _NATIVE_LIMITS):
        if not -m < v < m:
            return None
    return array("H", [(v >> s) & 0xFFFF for v in flat for s in (0, 16, 32, 48)])


class ExactCorrection:
    """h_c = M (s / n - b) for integer inputs s, each a sum of n codes (n=1: codes).

    cal: a Calibration (its exact_pairs() and, with `tau`, its tempco at tau = T - t0_c C).
    """

    def __init__(self, cal, n, tau=None):
        self.divisor = n
        self.tau = tau
        mp, bp = cal.exact_pairs()
        b = [fraction(p) for p in bp]
        gain = [(1, 1)] * 3
        if tau is not None and cal.tempco is not None:
            tc = cal.tempco
            for j in range(3):
                # the gain factor 1 / (1 + g tau) and the offset b + o tau, exact from the
                # interpreter's float products g tau and o tau
                gn, gd = fraction(float_pair(tc["gain_per_c"][j] * tau))
                gain[j] = (gd, gd + gn)
                on, od = fraction(float_pair(tc["offset_per_c"][j] * tau))
                b[j] = (b[j][0] * od + on * b[j][1], b[j][1] * od)
        # n b = w + r: w the nearest integer (subtracted from the input exactly), r the rest;
        # coefficients C[i][j] = M[i][j] g_j 1000 2**_COEF_BITS / n and the rest's share
        # K[i] = sum_j C[i][j] r_j, each rounded once from its exact fraction
        self._w = [_round_div(n * num, den) for num, den in b]
        self._c = []
        self._k = []
        for i in range(3):
            row = []
            kn, kd = 0, 1
            for j in range(3):
                num, den = fraction(mp[i][j], 1000 * gain[j][0], n * gain[j][1], _COEF_BITS)
                row.append(_round_div(num, den))
                rn, rd = n * b[j][0] - self._w[j] * b[j][1], b[j][1]
                kn, kd = kn * den * rd + num * rn * kd, kd * den * rd
            self._c.append(row)
            self._k.append(_round_div(kn, kd))
        # the per-sample path's numbers as one tuple: unpacked into locals in one step
        self._flat = tuple(self._w + self._c[0] + self._c[1] + self._c[2] + self._k + [_COEF_BITS - FRACTION_BITS])
        # the native |h_c| where every number fits its words, decided here once
        self._native = native_numbers(self._flat)
        if self._native is None and _native_magnitude is not None:
            self.magnitude = self._magnitude        # the pure-Python method, without the native try
        self.path = "python" if self._native is None else "native"

    def _axes(self, sx, sy, sz):
        """h_c in 1/2**FRACTION_BITS milli-nT, floored (ints)."""
        w0, w1, w2, c00, c01, c02, c10, c11, c12, c20, c21, c22, k0, k1, k2, d = self._flat
        ex = sx - w0
        ey = sy - w1
        ez = sz - w2
        return ((c00 * ex + c01 * ey + c02 * ez - k0) >> d, (c10 * ex + c11 * ey + c12 * ez - k1) >> d,
                (c20 * ex + c21 * ey + c22 * ez - k2) >> d)

    def _magnitude(self, sx, sy, sz):
        """|h_c| in pure Python (the reference): isqrt's steps inline, as each call costs on a
        board."""
        w0, w1, w2, c00, c01, c02, c10, c11, c12, c20, c21, c22, k0, k1, k2, d = self._flat
        ex = sx - w0
        ey = sy - w1
        ez = sz - w2
        hx = (c00 * ex + c01 * ey + c02 * ez - k0) >> d
        hy = (c10 * ex + c11 * ey + c12 * ez - k1) >> d
        hz = (c20 * ex + c21 * ey + c22 * ez - k2) >> d
        q = hx * hx + hy * hy + hz * hz
        if q < 2:
            return q
        x = int(math.sqrt(q)) + 1
        y = (x + q // x) >> 1
        while y * y > q:
            y -= 1
        return y

    if _native_magnitude is None:
        magnitude = _magnitude
    else:
        def magnitude(self, sx, sy, sz):
            """|h_c| in 1/2**FRACTION_BITS milli-nT (an int, floored): in C (fitsums.magnitude) where
            `path` is "native" and the sums fit its words, else _magnitude."""
            f = _native_magnitude(self._native, sx, sy, sz)
            return self._magnitude(sx, sy, sz) if f is None else f

    def _correct(self, sx, sy, sz):
        """h_c in milli-nT (a tuple of ints, rounded to the nearest; the reference)."""
        hx, hy, hz = self._axes(sx, sy, sz)
        r = 1 << (FRACTION_BITS - 1)
        return ((hx + r) >> FRACTION_BITS, (hy + r) >> FRACTION_BITS, (hz + r) >> FRACTION_BITS)

    if _native_correct is None:
        correct = _correct
    else:
        def correct(self, sx, sy, sz):
            """h_c in milli-nT: in C (fitsums.correct, a tuple of small ints) where `path` is "native"
            and the sums and results fit its words, else _correct (big ints on a 32-bit port)."""
            b = None if self._native is None else _native_correct(self._native, sx, sy, sz)
            return self._correct(sx, sy, sz) if b is None else b


def isqrt(q):
    """floor(sqrt(q)) of an int q >= 0, exact: a float's guess, one Newton step, a fix-up."""
    if q < 2:
        return q
    x = int(math.sqrt(q)) + 1        # within the float's width of the root: > 0
    y = (x + q // x) >> 1            # Newton from any x > 0 lands at or above floor(sqrt(q))
    while y * y > q:                 # one or two steps down after a float's guess
        y -= 1
    return y


def check_exact(ex, matrix, offset):
    """The record's "exact" object ({"matrix": 3x3 [m, e], "offset": 3 [m, e]}) validated
    against its matrix and offset (floats), as (3x3 pairs, 3 pairs); ValueError naming the
    first problem. Each pair: two integers, m within a float64's 53 bits, and equal to the
    float to a few units in the last place of a 30-bit float (a board prints 7 digits),
    relative to the entry or, near zero, to the largest entry."""
    try:
        rows = [ex["offset"]] + list(ex["matrix"])
        if len(rows) != 4 or any(len(r) != 3 for r in rows):
            rows = None
    except Exception:
        rows = None
    if rows is None:
        raise ValueError("exact must be {\"matrix\": 3x3 [m, e], \"offset\": 3 [m, e]}")
    big = max(abs(v) for row in matrix for v in row)
    out = []
    for i in range(4):
        for j in range(3):
            p = rows[i][j]
            what = "exact.offset[%d]" % j if i == 0 else "exact.matrix[%d][%d]" % (i - 1, j)
            x = offset[j] if i == 0 else matrix[i - 1][j]
            if (not isinstance(p, list) or len(p) != 2 or not all(isinstance(v, int) and not isinstance(v, bool) for v in p)
                    or not (-(1 << 53) < p[0] < (1 << 53) and -1100 <= p[1] <= 1100)):
                raise ValueError("%s must be [m, e]: two integers, |m| < 2**53, |e| <= 1100" % what)
            if abs(math.ldexp(float(p[0]), p[1]) - x) > 2.0 ** -19 * (abs(x) + (1.0 if i == 0 else big * 2.0 ** -20)):
                raise ValueError("%s is not the record's %s (%.9g)" % (what, what[6:], x))
            out.append((p[0], p[1]))
    return [out[3:6], out[6:9], out[9:12]], out[0:3]
