"""The calibration: h_c = M (h_r - b), and its JSON-ready record.

    from shared.calibration import Calibration
    cal = Calibration(matrix, offset, field)
    cal.correct(x, y, z)      # -> (x, y, z) in the output unit (nT)
    cal.magnitude(x, y, z)    # -> |h_c|
    d = cal.to_dict()         # {"version": 1, "matrix": 3x3 row-major, "offset": 3, "field": nT, ...}
    cal = Calibration.from_dict(d)   # validated deeply: ValueError naming the problem
    cal.at_temperature(t)     # with a "tempco": the calibration at t C (docs/temperature.md)

``offset`` is in the raw input unit (ADC codes, or nT for a file), ``matrix`` maps that unit to
the output unit, ``field`` is the magnitude the calibration was fitted to (the known local
field, or the fitted radius).

Every record that enters from outside (the wire's set-cal, cal.json at boot, a file on the
laptop) goes through from_dict, the one validator: every field, nested ones included, against
bounds a magnetometer can have. A record that passes cannot make the survey raise later
(docs/reliability.md, row "set-cal bricks"). The constructor, used by the fit itself, checks
only what the arithmetic needs.

Temperature coefficients (optional key "tempco", fitted by shared/tempco.py): {"t0_c": C,
"offset_per_c": [3] input units per C, "gain_per_c": [3] relative gain change per C of each raw
axis, "range_c": [lo, hi] C measured over, "sources": int, "method": "calibrations" | "warmup"}.
With tau = T - t0_c the sensor's raw reading has offset b + offset_per_c tau and raw axis i gain
(1 + gain_per_c[i] tau) times its gain at t0_c, so

    h_c = M diag(1 / (1 + gain_per_c tau)) (h - b - offset_per_c tau)

(at_temperature). The matrix and offset of the record are those at t0_c.

The sensor's response (optional key "response", shared/response.py): the time constants
a slow sensor's lag is undone with before M and b apply; carried along, not applied here.
"""

import math

from shared.fixedpoint import check_exact, float_pair
from shared.response import check_response

FORMAT_VERSION = 1

FIELD_RANGE_NT = (1000.0, 100000.0)   # the Earth's field is 22,000-67,000 nT
# |offset| in the input unit: the ADS1292's full scale is 2**23 codes [DS 8.3.8]; as nT,
# 8.4 mT, a hundred times any fluxgate's range
OFFSET_LIMIT = 8388608.0
# sigma_max / sigma_min of M in nT per nT (columns divided by meta["scale"] when the record
# takes codes). A fluxgate's axes differ by a few % in gain and < 1 deg in angle (cond < 1.1);
# the cheap MEMS sensors in ../shared/data/real with their soft iron reach 2.2; an axis
# skewed by 45 deg is 2.4, by 89 deg 115.
COND_LIMIT = 3.0
SYMMETRY_TOL = 1e-5   # M is symmetric by construction (every fit here); relative to max |m_ij|
TEMP_RANGE_C = (-60.0, 130.0)   # the ADS1292's die: -40..85 C operating [DS 6.3], with margin
_TEXT_MAX = 256
# a finite number's bound, parsed at run time: MicroPython's freezing tool refuses a literal beyond float32
_HUGE = float("1e300")
# known fields and their types: a wrong type is refused, not carried into the survey
_META_NUMBERS = ("temperature_c", "time", "uptime_ms", "rate", "n")
_META_TEXT = ("firmware", "source", "units", "method", "time_iso")
_DIAG_NUMBERS = ("n", "rms", "observability", "predicted_error", "iterations", "radius", "rejected")
# tempco bounds. Offsets: the ADC's whole range (OFFSET_LIMIT) over 1000 C. In codes of the
# handheld (0.0144 nT) that is 121 nT/C, a hundred times a real fluxgate's ~1 nT/C; in nT
# (files) 8,400 nT/C, as loose as OFFSET_LIMIT is there. Gains: 1e-3 per C is 50 times the
# simulator's fluxgate bound (20 ppm/C) and 20 times the ADS1292's reference (45 ppm/C), and
# keeps 1 + gain tau >= 0.81 across TEMP_RANGE_C, so the model never reverses an axis.
TEMPCO_OFFSET_LIMIT = OFFSET_LIMIT / 1000.0
TEMPCO_GAIN_LIMIT = 1e-3
TEMPCO_METHODS = ("calibrations", "warmup")
_TEMPCO_KEYS = ("t0_c", "offset_per_c", "gain_per_c", "range_c", "sources", "method")


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


def _temperature(value, what):
    t = _number(value, what)
    if not TEMP_RANGE_C[0] <= t <= TEMP_RANGE_C[1]:
        raise ValueError("%s %r outside %r..%r C" % (what, t, TEMP_RANGE_C[0], TEMP_RANGE_C[1]))
    return t


def check_tempco(tc):
    """The tempco record tc validated deeply, as a new dict of floats and lists; ValueError
    naming the first problem. Keys besides the six known ones may carry JSON scalars
    (as meta's may)."""
    if not isinstance(tc, dict):
        raise ValueError("tempco must be a JSON object")
    for k in _TEMPCO_KEYS:
        if k not in tc:
            raise ValueError("tempco has no %r" % k)
    out = {}
    for k in tc:
        if k not in _TEMPCO_KEYS:
            if not _scalar(tc[k]):
                raise ValueError("tempco.%s: a number, short text, true/false or null expected"
                                 % (_short(k)[1:-1] if isinstance(k, str) else _short(k)))
            out[k] = tc[k]
    out["t0_c"] = _temperature(tc["t0_c"], "tempco.t0_c")
    o = _vector(tc["offset_per_c"], "tempco.offset_per_c")
    g = _vector(tc["gain_per_c"], "tempco.gain_per_c")
    for i in range(3):
        if abs(o[i]) > TEMPCO_OFFSET_LIMIT:
            raise ValueError("tempco.offset_per_c[%d] %.6g beyond +-%.6g per C" % (i, o[i], TEMPCO_OFFSET_LIMIT))
        if abs(g[i]) > TEMPCO_GAIN_LIMIT:
            raise ValueError("tempco.gain_per_c[%d] %.6g beyond +-%g per C" % (i, g[i], TEMPCO_GAIN_LIMIT))
    out["offset_per_c"] = o
    out["gain_per_c"] = g
    r = tc["range_c"]
    if not isinstance(r, (list, tuple)) or len(r) != 2:
        raise ValueError("tempco.range_c must be [lo, hi] in C")
    lo = _temperature(r[0], "tempco.range_c[0]")
    hi = _temperature(r[1], "tempco.range_c[1]")
    if lo > hi:
        raise ValueError("tempco.range_c [%r, %r]: lo above hi" % (lo, hi))
    out["range_c"] = [lo, hi]
    n = tc["sources"]
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1000000:
        raise ValueError("tempco.sources must be an integer 1..1000000")
    out["sources"] = n
    if tc["method"] not in TEMPCO_METHODS:
        raise ValueError("tempco.method must be one of %s" % ", ".join(TEMPCO_METHODS))
    out["method"] = tc["method"]
    return out


class Calibration:
    def __init__(self, matrix, offset, field, diagnostics=None, meta=None, tempco=None, response=None):
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
        # temperature coefficients (module docstring), validated whole, or None
        self.tempco = None if tempco is None else check_tempco(tempco)
        self.response = None if response is None else check_response(response)
        # The offset as an integer and a fraction (|frac| <= 0.5, exact): an integer
        # input (ADC codes, boxcar sums) has the integer part subtracted in integer
        # arithmetic, so no code of several million becomes a float before it is
        # centred (a 30-bit float holds integers to 2**22 only: float(5000001) is
        # 5000000.0 there).
        self._b_int = [int(math.floor(b + 0.5)) for b in self.offset]
        self._b_frac = [b - bi for b, bi in zip(self.offset, self._b_int)]
        self._exact = None   # M and b as exact pairs (exact_pairs)

    def exact_pairs(self):
        """(3x3, 3) of (m, e): M, b exactly as m * 2**e (shared/fixedpoint.py): the record's, else the floats'."""
        if self._exact is None:
            self._exact = ([[float_pair(v) for v in row] for row in self.matrix], [float_pair(v) for v in self.offset])
        return self._exact

    def _use_exact(self, mp, bp):
        """The record's exact pairs; the floats too where this float holds them (CPython: all)."""
        self._exact = (mp, bp)
        for i in range(9):
            p = mp[i // 3][i % 3]
            if int(float(p[0])) == p[0]:      # this float holds it
                self.matrix[i // 3][i % 3] = math.ldexp(float(p[0]), p[1])
        for j in range(3):
            if int(float(bp[j][0])) == bp[j][0]:
                self.offset[j] = math.ldexp(float(bp[j][0]), bp[j][1])
                self._b_int[j] = int(math.floor(self.offset[j] + 0.5))
                self._b_frac[j] = self.offset[j] - self._b_int[j]

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
        """The same calibration for inputs measured in `unit` times larger steps (a number,
        or one per axis).

        A fit on integers n = round(h / unit) gives h_c = M (n - b); in terms of h
        that is (M / unit)(h - b * unit), M's columns divided axis by axis.
        """
        u = unit if isinstance(unit, (list, tuple)) else (unit, unit, unit)
        tc = self.tempco
        if tc is not None:
            tc = dict(tc)
            tc["offset_per_c"] = [v * k for v, k in zip(tc["offset_per_c"], u)]
        return Calibration(
            [[row[j] / u[j] for j in range(3)] for row in self.matrix],
            [v * k for v, k in zip(self.offset, u)],
            self.field,
            self.diagnostics,
            self.meta,
            tc,
            self.response,
        )

    def at_temperature(self, temp_c):
        """The calibration at temp_c (C) from the tempco (self without one): no tempco,
        meta.temperature_c = temp_c.

        M(T) = M diag(1 / (1 + g tau)), b(T) = b + o tau, tau = temp_c - t0_c. The
        offset's integer part stays the record's; the drift moves only the small part
        (a 30-bit float cannot hold an offset of millions of codes to a fraction).
        About 40 float operations: cheap at every temperature update.
        """
        tc = self.tempco
        if tc is None:
            return self
        c = self._drifted(tc["offset_per_c"], tc["gain_per_c"], temp_c - tc["t0_c"])
        c.meta["temperature_c"] = temp_c
        return c

    def _drifted(self, offset_per_c, gain_per_c, tau):
        """This calibration (no tempco) after a drift of tau C: at_temperature's model."""
        g = gain_per_c
        d0 = 1.0 / (1.0 + g[0] * tau)
        d1 = 1.0 / (1.0 + g[1] * tau)
        d2 = 1.0 / (1.0 + g[2] * tau)
        c = Calibration([[row[0] * d0, row[1] * d1, row[2] * d2] for row in self.matrix], self.offset,
                        self.field, self.diagnostics, self.meta, None, self.response)
        bi = self._b_int
        c._b_int = list(bi)
        c._b_frac = [self._b_frac[i] + offset_per_c[i] * tau for i in range(3)]
        c.offset = [bi[i] + c._b_frac[i] for i in range(3)]
        return c

    def tempco_in_range(self, temp_c):
        """True if the tempco was measured over a range that holds temp_c (False: none)."""
        tc = self.tempco
        return tc is not None and tc["range_c"][0] <= temp_c <= tc["range_c"][1]

    def to_dict(self):
        d = {
            "version": FORMAT_VERSION,
            "matrix": [list(row) for row in self.matrix],
            "offset": list(self.offset),
            "field": self.field,
            "diagnostics": dict(self.diagnostics),
            "meta": dict(self.meta),
        }
        d["exact"] = {"matrix": [[list(p) for p in r] for r in self.exact_pairs()[0]], "offset": [list(p) for p in self._exact[1]]}
        if self.tempco is not None:
            tc = dict(self.tempco)
            for k in ("offset_per_c", "gain_per_c", "range_c"):
                tc[k] = list(tc[k])
            d["tempco"] = tc
        if self.response is not None:
            d["response"] = dict(self.response)
            for k in ("tau_s", "tau_sigma_s"):
                if k in d["response"]:
                    d["response"][k] = list(d["response"][k])
        return d

    @classmethod
    def from_dict(cls, d):
        """The record d (a JSON object) as a Calibration, or ValueError naming its first problem."""
        if not isinstance(d, dict):
            raise ValueError("calibration must be a JSON object")
        version = d.get("version", FORMAT_VERSION)
        if version != FORMAT_VERSION:
            raise ValueError("unsupported calibration version %r" % (_short(version),))
        for key in ("matrix", "offset", "field"):
            if key not in d:
                raise ValueError("calibration has no %r" % key)
        diagnostics = d.get("diagnostics") or {}
        meta = d.get("meta") or {}
        if not isinstance(diagnostics, dict) or not isinstance(meta, dict):
            raise ValueError("diagnostics and meta must be JSON objects")
        _check_fields(meta, "meta", _META_NUMBERS, _META_TEXT)
        _check_fields(diagnostics, "diagnostics", _DIAG_NUMBERS, ())
        cal = cls(d["matrix"], d["offset"], d["field"], diagnostics, meta, d.get("tempco"), d.get("response"))
        if "exact" in d:
            cal._use_exact(*check_exact(d["exact"], cal.matrix, cal.offset))
        problem = plausibility_problem(cal)
        if problem:
            raise ValueError(problem)
        return cal

    def __repr__(self):
        return "Calibration(field=%.3f, offset=%r)" % (self.field, self.offset)


def _short(v):
    """A value for an error message, at most 40 characters of it."""
    t = repr(v)
    return t if len(t) <= 40 else t[:37] + "..."


def _scalar(v):
    """A JSON scalar a record may carry in an unknown field: a finite number, text, bool or null."""
    if v is None or isinstance(v, bool):
        return True
    if isinstance(v, (int, float)):
        return -_HUGE < v < _HUGE   # finite (a 400-digit integer is not a measurement either)
    return isinstance(v, str) and len(v) <= _TEXT_MAX


def _check_fields(d, what, numbers, texts):
    for k in d:
        v = d[k]
        name = "%s.%s" % (what, _short(k)[1:-1] if isinstance(k, str) else _short(k))
        if k in numbers:
            if v is not None:
                _number(v, name)
        elif k in texts:
            if not (isinstance(v, str) and len(v) <= _TEXT_MAX):
                raise ValueError("%s must be text of at most %d characters" % (name, _TEXT_MAX))
        elif k == "scale":
            s = _vector(v, name)
            if not (s[0] > 0 and s[1] > 0 and s[2] > 0):
                raise ValueError("%s must be 3 positive numbers (nT per unit)" % name)
        elif isinstance(v, list):
            if len(v) > 8 or not all(_scalar(e) for e in v):
                raise ValueError("%s: a list of at most 8 numbers or short texts expected" % name)
        elif not _scalar(v):
            raise ValueError("%s: a number, short text, true/false or null expected" % name)
    t = d.get("temperature_c") if what == "meta" else None
    if t is not None and not TEMP_RANGE_C[0] <= t <= TEMP_RANGE_C[1]:
        raise ValueError("meta.temperature_c %r outside %r..%r C" % (t, TEMP_RANGE_C[0], TEMP_RANGE_C[1]))


def _sym_eigenvalues(a):
    """Eigenvalues of a symmetric 3x3 matrix, closed form (Smith 1961); ascending."""
    p1 = a[0][1] ** 2 + a[0][2] ** 2 + a[1][2] ** 2
    q = (a[0][0] + a[1][1] + a[2][2]) / 3.0
    p2 = (a[0][0] - q) ** 2 + (a[1][1] - q) ** 2 + (a[2][2] - q) ** 2 + 2.0 * p1
    p = math.sqrt(p2 / 6.0)
    if p == 0.0:
        return [q, q, q]
    b = [[(a[i][j] - (q if i == j else 0.0)) / p for j in range(3)] for i in range(3)]
    r = (b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
         + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0])) / 2.0
    phi = math.acos(max(-1.0, min(1.0, r))) / 3.0
    e1 = q + 2.0 * p * math.cos(phi)
    e3 = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    return [e3, 3.0 * q - e1 - e3, e1]


def plausibility_problem(cal):
    """Why cal cannot be a magnetometer's (one line), or None: the bounds a record must meet.

    The field one the Earth has; offsets within the ADC's range; M symmetric positive
    definite (no axis reversed or swapped) with a condition number a sensor can have.
    """
    lo, hi = FIELD_RANGE_NT
    if not lo <= cal.field <= hi:
        return "field %.6g nT is implausible: the Earth's is 22,000-67,000 nT, fluxcal accepts 1,000-100,000 nT" % (
            cal.field,)
    for i in range(3):
        if abs(cal.offset[i]) > OFFSET_LIMIT:
            return "offset[%d] %.6g beyond the ADC's range (+-%d codes)" % (i, cal.offset[i], OFFSET_LIMIT)
    m = cal.matrix
    big = max(abs(v) for row in m for v in row)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        if abs(m[i][j] - m[j][i]) > SYMMETRY_TOL * big:
            return "matrix is not symmetric (m[%d][%d] %.6g, m[%d][%d] %.6g)" % (i, j, m[i][j], j, i, m[j][i])
    k = cal.meta.get("scale") or (1.0, 1.0, 1.0)
    # in nT per nT: h = k n, so M (n - b) = M K^-1 (h - k b)
    a = [[m[i][j] / k[j] for j in range(3)] for i in range(3)]
    s = [[(a[i][j] + a[j][i]) / 2.0 for j in range(3)] for i in range(3)]
    ev = _sym_eigenvalues(s)
    if not ev[0] > 0:
        return "matrix is not positive definite (smallest eigenvalue %.3g): an axis reversed or swapped" % ev[0]
    ata = [[a[0][i] * a[0][j] + a[1][i] * a[1][j] + a[2][i] * a[2][j] for j in range(3)] for i in range(3)]
    sv = _sym_eigenvalues(ata)   # squared singular values
    cond = math.sqrt(sv[2] / sv[0]) if sv[0] > 0 else float("inf")
    if cond > COND_LIMIT:
        return "matrix condition number %.3g > %g: gains or axis angles no magnetometer has" % (cond, COND_LIMIT)
    return None
