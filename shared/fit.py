"""Streaming ellipsoid fit: constant memory, exact, order-independent.

    from shared.fit import EllipsoidFit, FitError
    fit = EllipsoidFit()
    fit.add(x, y, z)          # integers: ADC codes or any fixed-point unit
    fit.remove(x, y, z)       # exact inverse of add (drop a disturbed segment)
    fit.merge(other)          # exact sum of two accumulators
    try:
        cal = fit.solve(field=None)       # -> shared.calibration.Calibration
    except FitError as exc:
        print(exc.reason)                 # too_few_samples, degenerate_coverage, ...
    cal = fit.solve(prior=previous)       # quick re-calibration (shared.quick)

The accumulator holds the 35 power sums x^i y^j z^k (i+j+k <= 4) as Python
integers, nothing else (shared.moments). Integers keep the sums exact, so the
result is the same whatever the order of the samples, the float width of the
machine, or how the samples were split between accumulators.

Float data (nT from a file) are quantised first: n = round(h / lsb) with a
step well below the noise (desktop.methods uses lsb = 0.001 nT, whose rounding
error lsb/sqrt(12) = 0.0003 nT rms is negligible beside any sensor's noise),
fitted with ``solve(scale=lsb)`` and mapped back with
``Calibration.scaled_input(lsb)``.
"""

from array import array

from shared import solver
from shared.errors import FitError  # noqa: F401 - the fit's error, imported from here by its users
from shared.iteration import MAX_ITER
from shared.moments import COUNT, bit_length
from shared.prior import SHAPE_SIGMA
from shared.solver import MIN_SAMPLES

try:
    import micropython  # noqa: F401  (MicroPython, CircuitPython)
    _STRICT = False
except ImportError:
    _STRICT = True
_INTS = "EllipsoidFit takes integers (quantise floats first)"

try:
    # The native sums (device/native/fitsums.c) where deploy installed the board's build:
    # MicroPython only. Elsewhere, and for codes it does not take, the packed integers below.
    import fitsums
except (ImportError, ValueError):    # ValueError: a .mpy of another architecture or version
    fitsums = None
# Which path sums the samples (the `status` key `sums`).
SUMS_PATH = "python" if fitsums is None else "native"
_native_add = None if fitsums is None else fitsums.add
# Samples the native words take before they are drained into the exact sums: each
# monomial of codes under 2**24 is under 2**96, so 2**24 of them stay inside the
# words' 128-bit two's complement (fitsums.c).
_DRAIN = 1 << 24

# Pending samples ride in eight packed integers (Kronecker substitution): slot j of
# a pack, bits [j*k, (j+1)*k), holds the running sum of one monomial, and each
# pack is a run of shared.moments.ORDER: (first storage index, slots).
_PACKS = ((1, 3), (4, 6), (10, 6), (16, 4), (20, 6), (26, 4), (30, 4), (34, 1))
# Samples a pack holds before it is unpacked into the exact sums. With inputs
# |v| <= 2**L, a slot's sum stays under _FLUSH * 2**(4L) = 2**(4L + 8) in
# magnitude, inside the balanced range of k = 4L + 10 bits.
_FLUSH = 256
_SPARE = 10


class EllipsoidFit:
    """The 35 power sums of the samples, exact.

    A sample's 34 monomials are built and summed in packed integers, 30
    big-integer operations instead of 75: on a microcontroller each one is a
    heap allocation, and their count, not the arithmetic, sets the cost
    (docs/firmware.md, instruction counts). The packs are unpacked into the
    plain sums every _FLUSH samples, before any read of the sums, and before a
    sample too large for the slot width; every result is the same integer as
    summing monomial by monomial. Where the native module fitsums is installed,
    codes under 2**24 are summed in its 128-bit machine words instead and drained
    into the same integers (SUMS_PATH says which path runs).
    """

    def __init__(self):
        self._s = [0] * COUNT
        self._add = [0] * len(_PACKS)     # packs of added samples
        self._sub = [0] * len(_PACKS)     # packs of removed samples
        self._k = 0                       # slot width (bits); 0: no packs yet
        self._bits = 20                   # input bits the slots are sized for
        self._bias = 0                    # inputs in [-bias, bias) fit the slots:
        self._span = 0                    #   0 <= (v + bias) < span = 2 * bias
        self._room = 0                    # samples the packs take before unpacking
        if fitsums is not None:
            self._words = array("i", [0] * fitsums.WORDS)    # the native sums: 34 x 128 bits, count, left
            self._words[fitsums.LEFT] = _DRAIN

    @classmethod
    def from_sums(cls, sums):
        """An accumulator holding the 35 power sums `sums` (shared.moments.ORDER): moved,
        merged or stored sums solved as if their samples had been added."""
        f = cls()
        f._s = list(sums)
        return f

    @property
    def n(self):
        """Number of samples accumulated."""
        return self._s[0] if fitsums is None else self._s[0] + self._words[fitsums.COUNT]

    def sums(self):
        """A copy of the 35 power sums (shared.moments.ORDER)."""
        self._unpack()
        return self._s[:]   # one block of 35 items (list() grows one by doubling)

    def low_sums(self):
        """A copy of the first 10 sums (the count, degree 1 and 2: shared.moments.ORDER). With the
        native words and no pack in use only those ten are drained, a quarter of a full drain's
        big-integer work (device/residuals.py reads them at every batch's end)."""
        if fitsums is not None and (not self._k or self._room == _FLUSH):
            self._take_words(10)
        else:
            self._unpack()
        return self._s[:10]

    def add(self, x, y, z, _out=False):
        # MicroPython and CircuitPython have no int-like types but bool: the slot check's `|`
        # rejects the rest (floats) for free. CPython's numpy integers would pass it and
        # overflow in the shifts, so there the type is checked (an isinstance costs ~600
        # instructions per argument on a Cortex-M).
        if _STRICT and not (isinstance(x, int) and isinstance(y, int) and isinstance(z, int)):
            raise TypeError(_INTS)
        b = self._bias
        try:
            g = (x + b) | (y + b) | (z + b)
        except TypeError:
            raise TypeError(_INTS)
        self._room -= 1
        if self._room < 0 or not 0 <= g < self._span:
            self._unpack(x, y, z)
        if _out:
            self._s[0] -= 1
            p = self._sub
        else:
            self._s[0] += 1
            p = self._add
        k = self._k
        # [y, z], [x, y, z]; [yy, yz, zz], [xx, xy, xz, yy, yz, zz]: each pack is a
        # small int times a pack plus a shifted pack, so no product is bigger than needed
        w = y + (z << k)
        v = x + (w << k)
        zz = z * z
        r = y * w + (zz << 2 * k)
        q = x * v + (r << 3 * k)
        c = x * q                         # xxx xxy xxz xyy xyz xzz
        zzz = z * zz
        t = y * r + (zzz << 3 * k)        # yyy yyz yzz zzz
        p[0] += v
        p[1] += q
        p[2] += c
        p[3] += t
        p[4] += x * c                     # x^4 .. xxzz
        p[5] += x * t                     # xyyy xyyz xyzz xzzz
        p[6] += y * t                     # y^4 .. yzzz
        p[7] += z * zzz

    if fitsums is not None:
        _add_packed = add

        def add(self, x, y, z, _out=False):
            # in C (a built-in in a class is not bound as a method, so this one call)
            _native_add(self, x, y, z, _out)

        def _add_slow(self, x, y, z, _out=False):
            # what the native add hands back: the words due for draining, or a code they do not
            # take (2**24 or more, a bool, a float to refuse): the packed way, into the same sums
            if self._words[fitsums.LEFT] <= 0:
                self._drain()
            self._add_packed(x, y, z, _out)

        def _drain(self):
            """Add the native words into the sums and zero them."""
            if self._words[fitsums.LEFT] < _DRAIN:
                self._take_words(COUNT)
            self._words[fitsums.LEFT] = _DRAIN

        def _take_words(self, end):
            """Add the count's and sums 1 .. end-1's native words into the sums and zero them: sum
            n is the 128-bit two's complement in words 4(n-1) .. 4n-1, least significant first
            (the top word signed). The words' LEFT stands: the others still hold their samples."""
            w = self._words
            s = self._s
            s[0] += w[fitsums.COUNT]
            w[fitsums.COUNT] = 0
            m = 0xFFFFFFFF
            for n in range(1, end):
                j = 4 * n - 4
                # the same integer built from fewer words where the upper ones only extend the
                # sign (a residual batch's sums, residuals.py: 32 bits for the degree-1 ones, 64
                # for degree 2): on a board each big-integer operation is an allocation
                lo = w[j]           # (read once: a word past a small int is a big one each read)
                a = w[j + 1]
                hi = w[j + 3]
                if w[j + 2] != hi or a >> 31 != hi:
                    v = (lo & m) | ((a & m) << 32) | ((w[j + 2] & m) << 64) | (hi << 96)
                elif a != (-1 if lo < 0 else 0):
                    v = (lo & m) | (a << 32)
                else:
                    v = lo
                if v:
                    s[n] += v
                w[j] = 0
                w[j + 1] = 0
                w[j + 2] = 0
                w[j + 3] = 0

    def remove(self, x, y, z):
        if self.n < 1:
            raise ValueError("remove from an empty fit")
        self.add(x, y, z, True)

    def _unpack(self, x=0, y=0, z=0):
        """Add the packs into the sums; then size the slots for inputs up to the
        largest of |x|, |y|, |z| with a bit of headroom (never narrower than before)."""
        if fitsums is not None:
            self._drain()
        k = self._k
        if k:
            s = self._s
            full = 1 << k
            half = full >> 1
            mask = full - 1
            for packs, sign in ((self._add, 1), (self._sub, -1)):
                for (first, count), a in zip(_PACKS, packs):
                    for i in range(first, first + count):
                        v = a & mask      # the slot, balanced: in [-half, half)
                        if v >= half:
                            v -= full
                        s[i] += sign * v
                        a = (a - v) >> k
                for j in range(len(packs)):
                    packs[j] = 0
        bits = max(bit_length(x) + 1, bit_length(y) + 1, bit_length(z) + 1, self._bits)
        self._bits = bits
        self._bias = 1 << bits
        self._span = 2 << bits
        self._k = 4 * bits + _SPARE
        self._room = _FLUSH

    def merge(self, other):
        self._unpack()
        other._unpack()
        s = self._s
        o = other._s
        for k in range(COUNT):
            s[k] += o[k]

    def solve(self, field=None, prior=None, num=float, scale=1.0, shape_sigma=SHAPE_SIGMA,
              min_samples=MIN_SAMPLES, max_iter=MAX_ITER, max_error=None, quick=True, refuse_worse=True,
              independent=1.0, between=None):
        """Fit h_c = M (h - b) with |h_c| constant; return a Calibration.

        field: the known local field in the output unit (nT), or None to fit it.
        prior: a previous Calibration on the same input unit: a quick
            re-calibration (shared.quick: its shape, today's offsets and common
            gain; FitError not_better if it would not improve on the prior).
        quick: False to fit all nine parameters with the prior as a weak one.
        refuse_worse: False to return a quick re-calibration even when it is not
            expected to beat the prior (a device's provisional estimate).
        independent: for a quick re-calibration, the share of samples that count as
            independent when the residuals are correlated (shared.quick.solve).
        between: None, or called between the solve's steps (its iterations; a quick
            re-calibration's stages too): a device drains its DRDY ring there.
        num: the number type of the float work (float on the device;
            numpy.float32 or a rounding class to emulate narrow floats).
        scale: nominal output unit per input unit, a number or 3 numbers
            (nT per ADC code per axis); sets the output unit when field is None
            and the frame of the physical prior.
        shape_sigma: (diagonal, off-diagonal) prior widths of the quadric's
            shape about a sphere (shared.prior.SHAPE_SIGMA: gains within 0.5 %,
            axes within 1 degree of orthogonal); None for no prior.
        max_error: reject (degenerate_coverage) if the predicted full-sphere
            calibration error exceeds this (output unit); default
            shared.result.MAX_ERROR_SHARE (1 %) of the field.

        M is symmetric positive definite in the nominal axes (no spurious
        rotation of the frame). Raises FitError with .reason in
        too_few_samples, degenerate_coverage, not_ellipsoid, non_finite, and for
        a quick re-calibration (prior, quick) also not_better.
        """
        self._unpack()
        if prior is not None and quick:
            from shared import quick as quick_fit
            return quick_fit.solve(self._s, prior, field, num, scale, shape_sigma, min_samples, max_iter, max_error,
                                   refuse_worse, quick_fit.GAIN_MODELS, independent, between)
        return solver.solve(self._s, field, prior, num, scale, shape_sigma, min_samples, max_iter, max_error,
                            between=between)
