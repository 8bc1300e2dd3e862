"""A warm-up's samples moved to one temperature, exactly, and fitted there.

    sp = [S0, S1, S2, S3, S4]                 # S_j = sum q^j m: every monomial m times the
                                              # temperature q (centidegrees) to the j
    sums = moved_sums(sp, offset_per_c, gain_per_c, offset, centre, bits)
    cal = solve_moved(sp, (offset_per_c, gain_per_c), offset, prior, field, scale, solve_kw)

For a given drift (offsets o and raw axis gains g per C) every moved monomial
is a polynomial in q of degree <= 4 times monomials of the sample, so the
moved power sums are integer combinations of S0..S4 (moved_sums). The drift
enters in fixed point, the rest in integers: the result is the power sums of
a point set to the final rounding. shared/warmup.py is the user.
"""

import math

from shared.calibration import Calibration
from shared.fit import EllipsoidFit
from shared.moments import BINOM, COUNT, INDEX, ORDER, bit_length

_FIX = 40               # fixed-point bits of the drift coefficients in moved_sums
FRAME_BITS = 34         # moved sums: the samples' spread scaled to ~2^34 (the solver's frame takes 2^40)



def recentre(sp, delta):
    """[S0..S4] about q = delta (integer centidegrees) from [S0..S4] about q = 0, exactly:
    sum (q - delta)^j m = sum_u C(j, u) (-delta)^(j-u) S_u."""
    if not delta:
        return sp
    out = []
    for j in range(5):
        row = [0] * COUNT
        for u in range(j + 1):
            c = BINOM[j][u] * (-delta) ** (j - u)
            src = sp[u]
            for k in range(COUNT):
                row[k] += c * src[k]
        out.append(row)
    return out


def _pmul(a, b):
    out = [0] * (len(a) + len(b) - 1)
    for i in range(len(a)):
        if a[i]:
            for j in range(len(b)):
                out[i + j] += a[i] * b[j]
    return out


def moved_sums(sp, offset_per_c, gain_per_c, offset, centre=(0, 0, 0), bits=0):
    """Power sums of the samples moved to the temperature sp is centred on, in a frame:
    sums of 2^bits (h' - centre), exact integers.

    sp: [S0..S4], S_j = sum q^j m over the samples (q in centidegrees from that
    temperature, per micro-block). A sample h at q becomes, per axis i,
    h'_i = h_i - tau (o_i + g_i (h_i - b_i)) with tau = q / 100 C (the drift model to
    first order in tau: gain (1 + g tau), offset b + o tau, shared/calibration.py): an
    affine map A(q) h + B(q) with A, B linear in q, so every moved monomial is a
    polynomial in q of degree <= 4 times monomials of h, whose sums are S0..S4.
    g and c = o - g b enter as _FIX-bit fixed point, the rest in integers, so the result
    is the power sums of a point set to the final rounding (a truncated expansion's
    residual sum of squares goes negative at a few parts in 1e11). Why the frame: the
    solver re-centres the sums, which multiplies the rounding of sum x by the centre
    cubed; about `centre` (integers near the offset) and with `bits` fractional bits
    that rounding stays far below the noise's share of the sums.
    """
    one = 1 << _FIX
    polys = []
    for i in range(3):
        g = _fixed(gain_per_c[i] / 100.0)
        c = _fixed((offset_per_c[i] - gain_per_c[i] * offset[i]) / 100.0)
        a = [one << bits, -(g << bits)]                           # A(q) 2^(F + bits)
        b = [-(centre[i] << (_FIX + bits)), -(c << bits)]         # B(q) 2^(F + bits), minus the centre
        pa = [[1]]
        pb = [[1]]
        for _ in range(4):
            pa.append(_pmul(pa[-1], a))
            pb.append(_pmul(pb[-1], b))
        # per exponent e, per t <= e: C(e, t) A^t B^(e - t), a polynomial in q
        polys.append([[[BINOM[e][t] * v for v in _pmul(pa[t], pb[e - t])] for t in range(e + 1)]
                      for e in range(5)])
    px, py, pz = polys
    out = []
    for k in range(COUNT):
        e = ORDER[k]
        total = 0
        for tx in range(e[0] + 1):
            for ty in range(e[1] + 1):
                pxy = _pmul(px[e[0]][tx], py[e[1]][ty])
                for tz in range(e[2] + 1):
                    p = _pmul(pxy, pz[e[2]][tz])
                    m = INDEX[(tx, ty, tz)]
                    for j in range(len(p)):
                        if p[j]:
                            total += p[j] * sp[j][m]
        den = 1 << (_FIX * (e[0] + e[1] + e[2]))
        out.append((2 * total + den) // (2 * den))
    return out


def frame_bits(s0):
    """Fractional bits for moved sums: the samples' rms spread times 2^bits about 2^FRAME_BITS."""
    n = s0[0]
    tr = 0
    for e1, e2 in (((1, 0, 0), (2, 0, 0)), ((0, 1, 0), (0, 2, 0)), ((0, 0, 1), (0, 0, 2))):
        tr += n * s0[INDEX[e2]] - s0[INDEX[e1]] * s0[INDEX[e1]]
    spread = (bit_length(tr // (n * n)) + 1) // 2
    return max(0, FRAME_BITS - spread)


def in_frame(cal, centre, bits):
    """cal for inputs 2^bits (h - centre)."""
    m = [[math.ldexp(v, -bits) for v in row] for row in cal.matrix]
    b = [math.ldexp((cal._b_int[i] - centre[i]) + cal._b_frac[i], bits) for i in range(3)]
    return Calibration(m, b, cal.field, cal.diagnostics, cal.meta)


def out_of_frame(cal, centre, bits):
    """The calibration for h of cal fitted to 2^bits (h - centre): the offset's integer
    part kept as an integer (shared/calibration.py)."""
    m = [[math.ldexp(v, bits) for v in row] for row in cal.matrix]
    rel = [math.ldexp(v, -bits) for v in cal.offset]
    c = Calibration(m, [centre[i] + rel[i] for i in range(3)], cal.field, cal.diagnostics, cal.meta)
    bi = [int(math.floor(v + 0.5)) for v in rel]
    c._b_int = [centre[i] + bi[i] for i in range(3)]
    c._b_frac = [rel[i] - bi[i] for i in range(3)]
    c.offset = [c._b_int[i] + c._b_frac[i] for i in range(3)]
    return c


def solve_moved(sp, lines, offset, prior, field, scale, solve_kw):
    """A full fit (prior None) or a quick one of the sums sp moved with lines = (o, g)
    about offset (None: not moved)."""
    if lines is None:
        return _solve_sums(sp[0], field=field, scale=scale, prior=prior, **solve_kw)
    centre = [int(math.floor(v + 0.5)) for v in offset]
    bits = frame_bits(sp[0])
    sums = moved_sums(sp, lines[0], lines[1], offset, centre, bits)
    if isinstance(scale, (int, float)):
        sc = math.ldexp(scale, -bits)
    else:
        sc = [math.ldexp(v, -bits) for v in scale]
    pr = None if prior is None else in_frame(prior, centre, bits)
    return out_of_frame(_solve_sums(sums, field=field, scale=sc, prior=pr, **solve_kw), centre, bits)


def _fixed(v):
    return int(math.floor(math.ldexp(v, _FIX) + 0.5))


def _solve_sums(sums, **kw):
    """EllipsoidFit.solve on given power sums (its whole state: the 35 sums, packs empty)."""
    return EllipsoidFit.from_sums(sums).solve(**kw)
