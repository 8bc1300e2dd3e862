"""Exact power sums of 3-D integer samples and their exact re-centring.

The 35 sums S[i,j,k] = sum x^i y^j z^k, i+j+k <= 4, are the sufficient
statistics of every quadric fit used here: for any centre and quadric the
normal matrix and gradient of sum (v^T A v - 1)^2 are polynomials of degree
<= 4 in v = h - b. Kept as Python integers (arbitrary precision on CPython and
on MicroPython's rp2/esp32/stm32/unix ports), they are exact: add/remove/merge
commute, and re-centring on a new point is an exact binomial expansion, so no
precision is lost however far the data sit from the origin.
"""

import math

# Exponent triples in storage order: by degree, then x-power descending, then
# y-power descending. EllipsoidFit.add writes the sums in exactly this order.
ORDER = []
for _d in range(5):
    for _i in range(_d, -1, -1):
        for _j in range(_d - _i, -1, -1):
            ORDER.append((_i, _j, _d - _i - _j))
INDEX = {}
for _n, _e in enumerate(ORDER):
    INDEX[_e] = _n
COUNT = len(ORDER)  # 35

BINOM = ((1,), (1, 1), (1, 2, 1), (1, 3, 3, 1), (1, 4, 6, 4, 1))


def _axis_sources(axis):
    """For each storage index n (exponents e), the storage indices of e with its `axis`
    exponent set to 0, 1, ..., e[axis], five bytes per n (a bytes object: one heap block,
    where a table of tuples would be hundreds of objects for every collection to mark)."""
    out = bytearray(5 * COUNT)
    for n, e in enumerate(ORDER):
        for t in range(e[axis] + 1):
            src = [e[0], e[1], e[2]]
            src[axis] = t
            out[5 * n + t] = INDEX[(src[0], src[1], src[2])]
    return bytes(out)


_SOURCES = [_axis_sources(_a) for _a in range(3)]


def shifted(sums, scale, centre):
    """Power sums of (scale*h - centre) from the power sums of h, exactly.

    sums: list of COUNT ints (storage order); scale: int; centre: 3 ints.
    (s*x - c)^i = sum_t C(i,t) s^t x^t (-c)^(i-t) shifts one axis at a time, x
    then y then z: 210 products in all, their coefficients made once per axis
    (the solver calls this per trial state; on a Cortex-M each big-integer
    product is a heap allocation, docs/firmware.md).
    """
    s = sums
    for axis in range(3):
        c = centre[axis]
        if c == 0 and scale == 1:
            continue
        mc = [1]
        sp = [1]
        for _ in range(4):
            mc.append(mc[-1] * -c)
            sp.append(sp[-1] * scale)
        coef = [[BINOM[e][t] * sp[t] * mc[e - t] for t in range(e + 1)] for e in range(5)]
        src = _SOURCES[axis]
        out = []
        for n in range(COUNT):
            row = coef[ORDER[n][axis]]
            base = 5 * n
            total = 0
            for t in range(len(row)):
                total += row[t] * s[src[base + t]]
            out.append(total)
        s = out
    return list(s) if s is sums else s


# bits of 0..255: the last step of bit_length is a table look-up
_BITS = bytes([0] + [len(bin(i)) - 2 for i in range(1, 256)])


def bit_length(x):
    """Number of bits of |x| (MicroPython ints have no int.bit_length).

    64 bits at a time while x is big, then bytes, then a table: a handful of
    operations instead of one shift per bit (the solver calls this for every
    conversion of a big integer to a float)."""
    if x < 0:
        x = -x
    n = 0
    while x >= 0x10000000000000000:
        x >>= 64
        n += 64
    while x >= 0x100:
        x >>= 8
        n += 8
    return n + _BITS[x]


def to_float(x, exponent=0):
    """float(x * 2**exponent) for an int x of any size, the same on every runtime.

    The integer is first cut to 53 significant bits with an integer shift
    (floor), so the conversion itself is exact and CPython and MicroPython give
    bit-identical doubles; on a 32-bit-float port the final rounding is the
    port's own. ldexp applies the power of two in one step, so no intermediate
    over- or underflows the narrow float range.
    """
    extra = bit_length(x) - 53
    if extra > 0:
        x >>= extra
        exponent += extra
    return math.ldexp(float(x), exponent)


def mean_centre(sums):
    """The integer nearest the sample mean (a convenient exact re-centring point)."""
    n = sums[0]
    return [(2 * sums[k] + n) // (2 * n) for k in (1, 2, 3)]
