"""Number types that emulate a narrow float on the desktop.

``RoundedFloat(bits)`` returns a class whose every arithmetic result is rounded
to `bits` significant bits (round half to even), like CircuitPython's 30-bit
float objects (REPR_C: 22 mantissa bits + the hidden bit, see
../shared/reference/ads1292-and-runtimes.md section 10). Pass it as the
``num`` of shared.fit.EllipsoidFit.solve; numpy.float32 emulates the 32-bit
ports the same way.
"""

import math


def _round(x, bits):
    if x == 0.0 or x != x or x in (math.inf, -math.inf):
        return x
    m, e = math.frexp(x)  # x = m 2^e, 0.5 <= |m| < 1
    return math.ldexp(round(m * (1 << bits)) / (1 << bits), e)


def RoundedFloat(bits):
    class Rounded:
        __slots__ = ("v",)
        BITS = bits

        def __init__(self, value=0.0):
            self.v = _round(float(value), bits)

        def __float__(self):
            return self.v

        def __repr__(self):
            return "Rounded%d(%r)" % (bits, self.v)

        def _other(self, o):
            return o.v if isinstance(o, Rounded) else _round(float(o), bits)

        def __add__(self, o):
            return Rounded(self.v + self._other(o))

        __radd__ = __add__

        def __sub__(self, o):
            return Rounded(self.v - self._other(o))

        def __rsub__(self, o):
            return Rounded(self._other(o) - self.v)

        def __mul__(self, o):
            return Rounded(self.v * self._other(o))

        __rmul__ = __mul__

        def __truediv__(self, o):
            return Rounded(self.v / self._other(o))

        def __rtruediv__(self, o):
            return Rounded(self._other(o) / self.v)

        def __neg__(self):
            return Rounded(-self.v)

        def __abs__(self):
            return Rounded(abs(self.v))

        def __eq__(self, o):
            return self.v == self._other(o)

        def __lt__(self, o):
            return self.v < self._other(o)

        def __le__(self, o):
            return self.v <= self._other(o)

        def __gt__(self, o):
            return self.v > self._other(o)

        def __ge__(self, o):
            return self.v >= self._other(o)

        def __hash__(self):
            return hash(self.v)

    Rounded.__name__ = "Rounded%d" % bits
    return Rounded
