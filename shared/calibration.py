"""The calibration: h_c = M (h_r - b), and its JSON-ready record.

    from shared.calibration import Calibration
    cal = Calibration(matrix, offset, field)
    cal.correct(x, y, z)      # -> (x, y, z) in the output unit (nT)
    cal.magnitude(x, y, z)    # -> |h_c|
    d = cal.to_dict()         # {"version": 1, "matrix": 3x3 row-major, "offset": 3, "field": nT, ...}
    cal = Calibration.from_dict(d)   # validated: ValueError naming the problem

``offset`` is in the raw input unit (ADC codes, or nT for a file), ``matrix``
maps that unit to the output unit, ``field`` is the magnitude the calibration
was fitted to (the known local field, or the fitted radius).
"""

import math

FORMAT_VERSION = 1


def _number(value, what):
    # bool is an int subclass; a JSON true where a number belongs is an error.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError("%s is not a number" % what)
    value = float(value)
    if value - value != 0:
        raise ValueError("%s is not finite" % what)
    return value


def _vector(value, what):
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError("%s must be a list of 3 numbers" % what)
    return [_number(v, "%s[%d]" % (what, i)) for i, v in enumerate(value)]


class Calibration:
    def __init__(self, matrix, offset, field, diagnostics=None, meta=None):
        if not isinstance(matrix, (list, tuple)) or len(matrix) != 3:
            raise ValueError("matrix must be 3 rows of 3 numbers")
        self.matrix = [_vector(row, "matrix[%d]" % i) for i, row in enumerate(matrix)]
        self.offset = _vector(offset, "offset")
        self.field = _number(field, "field")
        if not self.field > 0:
            raise ValueError("field must be positive")
        m = self.matrix
        det = (
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        )
        # A singular or mirroring matrix cannot come from a physical sensor.
        if not det > 0:
            raise ValueError("matrix must have a positive determinant")
        self.diagnostics = dict(diagnostics) if diagnostics else {}
        self.meta = dict(meta) if meta else {}
        # The offset as an integer and a fraction (|frac| <= 0.5, exact): an integer
        # input (ADC codes, boxcar sums) has the integer part subtracted in integer
        # arithmetic, so no code of several million becomes a float before it is
        # centred (a 30-bit float holds integers to 2**22 only: float(5000001) is
        # 5000000.0 there).
        self._b_int = [int(math.floor(b + 0.5)) for b in self.offset]
        self._b_frac = [b - bi for b, bi in zip(self.offset, self._b_int)]

    def correct(self, x, y, z):
        m = self.matrix
        bi = self._b_int
        bf = self._b_frac
        dx = (x - bi[0]) - bf[0]
        dy = (y - bi[1]) - bf[1]
        dz = (z - bi[2]) - bf[2]
        return (
            m[0][0] * dx + m[0][1] * dy + m[0][2] * dz,
            m[1][0] * dx + m[1][1] * dy + m[1][2] * dz,
            m[2][0] * dx + m[2][1] * dy + m[2][2] * dz,
        )

    def magnitude(self, x, y, z):
        cx, cy, cz = self.correct(x, y, z)
        return math.sqrt(cx * cx + cy * cy + cz * cz)

    def scaled_input(self, unit):
        """The same calibration for inputs measured in `unit` times larger steps.

        A fit on integers n = round(h / unit) gives h_c = M (n - b); in terms of h
        that is (M / unit)(h - b * unit).
        """
        return Calibration(
            [[v / unit for v in row] for row in self.matrix],
            [v * unit for v in self.offset],
            self.field,
            self.diagnostics,
            self.meta,
        )

    def to_dict(self):
        return {
            "version": FORMAT_VERSION,
            "matrix": [list(row) for row in self.matrix],
            "offset": list(self.offset),
            "field": self.field,
            "diagnostics": dict(self.diagnostics),
            "meta": dict(self.meta),
        }

    @classmethod
    def from_dict(cls, d):
        if not isinstance(d, dict):
            raise ValueError("calibration must be a JSON object")
        version = d.get("version", FORMAT_VERSION)
        if version != FORMAT_VERSION:
            raise ValueError("unsupported calibration version %r" % (version,))
        for key in ("matrix", "offset", "field"):
            if key not in d:
                raise ValueError("calibration has no %r" % key)
        diagnostics = d.get("diagnostics") or {}
        meta = d.get("meta") or {}
        if not isinstance(diagnostics, dict) or not isinstance(meta, dict):
            raise ValueError("diagnostics and meta must be JSON objects")
        return cls(d["matrix"], d["offset"], d["field"], diagnostics, meta)

    def __repr__(self):
        return "Calibration(field=%.3f, offset=%r)" % (self.field, self.offset)
