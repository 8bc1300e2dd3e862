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


def _axis_chains(axis):
    """The chains along `axis`: for each monomial m of the other two axes with degree below 4,
    the storage indices of m x^0, m x^1, ..., m x^(4 - deg m), each chain prefixed by its
    length, all in one bytes object (one heap block for a collection to mark, where a table
    of tuples would be dozens)."""
    out = bytearray()
    for e in ORDER:
        if e[axis] == 0 and e[0] + e[1] + e[2] < 4:
            out.append(5 - (e[0] + e[1] + e[2]))
            for t in range(5 - (e[0] + e[1] + e[2])):
                src = [e[0], e[1], e[2]]
                src[axis] = t
                out.append(INDEX[(src[0], src[1], src[2])])
    return bytes(out)


_CHAINS = [_axis_chains(_a) for _a in range(3)]
DEGREE = bytes([_e[0] + _e[1] + _e[2] for _e in ORDER])


def _taylor(s, chains, c):
    """Re-centre one axis of the sums s (a list, in place) on c: along each chain the moments
    M_t = sum m x^t become sum m (x - c)^t = sum_j C(t, j) (-c)^(t-j) M_j, by the Taylor
    shift M_t -= c M_(t-1) for t from the top down to k, passes k = 1 .. d (the binomial
    coefficients built up by the repeated passes): d(d+1)/2 products for a chain of degree d,
    35 an axis, each with a small factor c where the centre moved little."""
    p = 0
    end = len(chains)
    while p < end:
        top = p + chains[p]          # the chain is chains[p + 1 .. top]
        for k in range(p + 2, top + 1):
            upper = chains[top]
            below = s[upper]
            for e in range(top - 1, k - 2, -1):
                lower = chains[e]
                value = s[lower]
                s[upper] = below - c * value
                upper = lower
                below = value
        p = top + 1


def recentred(sums, centre):
    """Power sums of (h - centre) from the power sums of h, exactly: a new list.

    sums: list of COUNT ints (storage order); centre: 3 ints. One axis at a time, x then
    y then z (_taylor): 105 big-integer products at most, fewer where the centre moves
    along fewer axes (the solver calls this per trial state, from the nearest state's sums;
    on a Cortex-M each big-integer operation is a heap allocation, docs/firmware.md).
    """
    s = sums[:]    # a slice is one block of COUNT items; list(sums) grows one by doubling to 64
    for axis in range(3):
        c = centre[axis]
        if c:
            _taylor(s, _CHAINS[axis], c)
    return s


def scaled(sums, scale):
    """Power sums of scale * h from those of h: each sum times scale^degree, exactly."""
    powers = [1, scale, scale * scale, scale * scale * scale, scale * scale * scale * scale]
    return [sums[n] * powers[DEGREE[n]] if DEGREE[n] else sums[n] for n in range(COUNT)]


def shifted(sums, scale, centre):
    """Power sums of (scale*h - centre) from the power sums of h, exactly.

    sums: list of COUNT ints (storage order); scale: int; centre: 3 ints.
    """
    return recentred(sums if scale == 1 else scaled(sums, scale), centre)


# bits of 0..255: the last step of bit_length is a table look-up
_BITS = bytes([0] + [len(bin(i)) - 2 for i in range(1, 256)])


def bit_length(x):
    """Number of bits of |x| (MicroPython ints have no int.bit_length).

    Halving steps of 128, 64, ... 8 bits, then a table: a fixed handful of operations
    (the solver calls this for every conversion of a big integer to a float, and the
    interpreter's cost is its operations)."""
    if x < 0:
        x = -x
    n = 0
    while x >= 0x100000000000000000000000000000000:
        x >>= 128
        n += 128
    if x >= 0x10000000000000000:
        x >>= 64
        n += 64
    if x >= 0x100000000:
        x >>= 32
        n += 32
    if x >= 0x10000:
        x >>= 16
        n += 16
    if x >= 0x100:
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
