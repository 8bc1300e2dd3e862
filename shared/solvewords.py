"""The solver's exact integer kernels in machine words, where the native module has them.

    words = pack(ints)                    # 35 sums as a bytearray of 320-bit words, or None
    out = recentre(words, centre)         # shared.moments.recentred in words, or None
    ga, t, rss = exact(words, a_int, n)   # shared.quadric.Problem.exact, or None
    ints = unpack(words)                  # the 35 ints back
    value = floats(words)                 # value(idx, exponent) == to_float(ints[idx], exponent)

On a 32-bit MicroPython port every big-integer operation is a heap allocation, and the
solver's re-centred sums (about 200 bits) and its exact RSS and gradient were a fifth of a
solve on the emulated Pico (docs/benchmarks.md). device/native/exact.h (in fitsums.mpy, which
deploy installs) does them in 320-bit two's complements instead: the same integers, and the
floats made from them here by the same float() and ldexp as shared.moments.to_float, so the
same floats on every interpreter. Where a number does not fit the words, or the module is
absent (CPython, CircuitPython, an older fitsums.mpy), every function returns None and the
caller uses the pure-Python integers (shared.quadric).
"""

import math
from array import array

from shared.moments import COUNT, _CHAINS

try:
    import fitsums      # MicroPython with deploy's native module (device/native/fitsums.c)
except (ImportError, ValueError):    # ValueError: a .mpy of another architecture or version
    fitsums = None
if fitsums is not None and not hasattr(fitsums, "tops"):
    fitsums = None      # a fitsums.mpy from before the solver's kernels

WORDS = 10 if fitsums is None else fitsums.SOLVE_WORDS
BYTES = 4 * WORDS
_FULL = 1 << (8 * BYTES)
_HALF = _FULL >> 1
_MASK = _FULL - 1
_M64 = (1 << 64) - 1
_B63 = 1 << 63
# the three axes' Taylor chains (shared.moments._CHAINS), each after its length
CHAINS = b"".join(bytes([len(c)]) + c for c in _CHAINS)


def available(frac):
    """Whether the kernels run here (for the fixed point of FRAC = frac fractional bits)."""
    return fitsums is not None and fitsums.SOLVE_FRAC == frac


def pack(ints):
    """The numbers as a bytearray of BYTES-byte two's complements, or None if one does not fit."""
    out = bytearray(len(ints) * BYTES)
    at = 0
    for x in ints:
        if not -_HALF <= x < _HALF:
            return None
        out[at:at + BYTES] = (x & _MASK).to_bytes(BYTES, "little")
        at += BYTES
    return out


def number(words, k):
    """Number k of a pack (an int)."""
    v = int.from_bytes(words[k * BYTES:(k + 1) * BYTES], "little")
    return v - _FULL if v >= _HALF else v


def unpack(words):
    return [number(words, k) for k in range(len(words) // BYTES)]


def _int64s(values):
    """64-bit two's complements of the values (bytes), or None if one does not fit."""
    out = bytearray(8 * len(values))
    for k, v in enumerate(values):
        if not -_B63 <= v < _B63:
            return None
        out[8 * k:8 * k + 8] = (v & _M64).to_bytes(8, "little")
    return out


def recentre(words, centre):
    """shared.moments.recentred(unpack(words), centre) as a pack, or None."""
    c = _int64s(centre)
    if c is None:
        return None
    out = bytearray(COUNT * BYTES)
    return out if fitsums.recentre(words, out, c, CHAINS) else None


def exact(words, a_int, n, tables):
    """Problem.exact's (g_A, T, RSS) from the sums in words (tables: quadric's index tables as
    bytes), or None."""
    a = _int64s(a_int)
    if a is None or not 0 <= n < (1 << 30):
        return None
    out = bytearray(10 * BYTES)
    if not fitsums.exact(words, a, n, tables, out):
        return None
    return [number(out, k) for k in range(6)], [number(out, k) for k in range(6, 9)], number(out, 9)


def floats(words):
    """value(idx, exponent): to_float(sum idx, exponent), from the C code's cut of each sum to
    53 bits (the integer to_float converts) and the shift it took."""
    cut = array("q", bytes(8 * COUNT))
    extra = array("H", bytes(2 * COUNT))
    fitsums.tops(words, cut, extra)

    def value(idx, exponent):
        return math.ldexp(float(cut[idx]), exponent + extra[idx])
    return value
