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

from shared import solver
from shared.moments import COUNT

FitError = solver.FitError


class EllipsoidFit:
    def __init__(self):
        self._s = [0] * COUNT

    @property
    def n(self):
        """Number of samples accumulated."""
        return self._s[0]

    def sums(self):
        """A copy of the 35 power sums (shared.moments.ORDER)."""
        return list(self._s)

    def add(self, x, y, z):
        if not (isinstance(x, int) and isinstance(y, int) and isinstance(z, int)):
            raise TypeError("EllipsoidFit.add takes integers (quantise floats first)")
        self._accumulate(x, y, z, 1)

    def remove(self, x, y, z):
        if not (isinstance(x, int) and isinstance(y, int) and isinstance(z, int)):
            raise TypeError("EllipsoidFit.remove takes integers")
        if self._s[0] < 1:
            raise ValueError("remove from an empty fit")
        self._accumulate(x, y, z, -1)

    def _accumulate(self, x, y, z, w):
        # w = +1 adds the sample, -1 removes it. Unrolled in
        # shared.moments.ORDER (degree, then x-power, then y-power descending);
        # the weight enters once, through the weighted quadratics.
        wx = w * x
        wy = w * y
        wz = w * z
        wxx = wx * x
        wxy = wx * y
        wxz = wx * z
        wyy = wy * y
        wyz = wy * z
        wzz = wz * z
        xx = x * x
        xy = x * y
        xz = x * z
        yy = y * y
        yz = y * z
        zz = z * z
        s = self._s
        s[0] += w
        s[1] += wx
        s[2] += wy
        s[3] += wz
        s[4] += wxx
        s[5] += wxy
        s[6] += wxz
        s[7] += wyy
        s[8] += wyz
        s[9] += wzz
        s[10] += wxx * x
        s[11] += wxx * y
        s[12] += wxx * z
        s[13] += wxy * y
        s[14] += wxy * z
        s[15] += wxz * z
        s[16] += wyy * y
        s[17] += wyy * z
        s[18] += wyz * z
        s[19] += wzz * z
        s[20] += wxx * xx
        s[21] += wxx * xy
        s[22] += wxx * xz
        s[23] += wxx * yy
        s[24] += wxx * yz
        s[25] += wxx * zz
        s[26] += wxy * yy
        s[27] += wxy * yz
        s[28] += wxy * zz
        s[29] += wxz * zz
        s[30] += wyy * yy
        s[31] += wyy * yz
        s[32] += wyy * zz
        s[33] += wyz * zz
        s[34] += wzz * zz

    def merge(self, other):
        s = self._s
        o = other._s
        for k in range(COUNT):
            s[k] += o[k]

    def solve(self, field=None, prior=None, num=float, scale=1.0, shape_sigma=(0.01, 0.0175),
              min_samples=12, max_iter=60, max_error=None):
        """Fit h_c = M (h - b) with |h_c| constant; return a Calibration.

        field: the known local field in the output unit (nT), or None to fit it.
        prior: a previous Calibration on the same input unit; ties shape, gain
            and offsets to it (quick re-calibration with little rotation).
        num: the number type of the float work (float on the device;
            numpy.float32 or a rounding class to emulate narrow floats).
        scale: nominal output unit per input unit, a number or 3 numbers
            (nT per ADC code per axis); sets the output unit when field is None
            and the frame of the physical prior.
        shape_sigma: (diagonal, off-diagonal) prior widths of the quadric's
            shape about a sphere: 0.01 for gains within 0.5 %, 0.0175 for axes
            within 1 degree of orthogonal; None for no prior.
        max_error: reject (degenerate_coverage) if the predicted full-sphere
            calibration error exceeds this (output unit); default 1 % of field.

        M is symmetric positive definite in the nominal axes (no spurious
        rotation of the frame). Raises FitError with .reason in
        too_few_samples, degenerate_coverage, not_ellipsoid, non_finite.
        """
        return solver.solve(self._s, field, prior, num, scale, shape_sigma, min_samples, max_iter, max_error)
