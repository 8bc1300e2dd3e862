"""Temperature coefficients of a calibration: offsets and per-axis gains per C.

    from shared.tempco import fit_tempco, attach, WarmupFit
    tc = fit_tempco([cal_cold, cal_warm])   # calibrations with meta["temperature_c"]
    cal = attach(cal_warm, tc)              # the record, compensated: cal.at_temperature(t)

    w = WarmupFit()                         # one long calibration while the temperature moves
    w.add(x, y, z, temp_c)                  # integers as EllipsoidFit.add, and the temperature
    cal = w.solve(scale=k)                  # the calibration at the mean temperature, with .tempco
    w.segments                              # what each temperature segment gave (its "kind")

The model (shared/calibration.py, docs/temperature.md): with tau = T - t0 the
raw offset is b + o tau and raw axis i's gain (1 + g_i tau) times its gain at
t0, so h_c = M diag(1 / (1 + g tau)) (h - b - o tau).

Where the numbers come from. A calibration's quadric is A = M^T M / F^2 (F the
record's field: the known one, or the fitted radius; A does not depend on
which). Raw axis gains D = diag(1 + g tau) turn the sensor's quadric A_ref into
D^-1 A_ref D^-1, whatever rotation the symmetric M of each fit carries, so
sqrt(A_ref,ii / A_ii) = 1 + g_i tau: the diagonal alone gives each raw axis's
gain against the reference, and a change of the fitted radius at one site is
the common gain (the ADC's reference moves every axis of its chip together).
Offsets are read directly. Least-squares lines of both against temperature
give o and g.

The warm-up (WarmupFit): temperature segments, each an exact accumulator plus
the sums of its monomials times powers of the temperature, so that its samples
can be moved to one temperature before they are fitted (moved_sums): without
that, the drift during a segment biases its fit (docs/temperature.md). Each
segment is fitted in full when its coverage allows (kind "full"), else as a
quick re-calibration on the whole's shape drifted to its temperature ("quick";
"kept" when that finds nothing better than the prediction, "failed" when it
fails); per-axis gains come from full segments only.

Arithmetic for 32-bit and 30-bit floats: everything is a difference from the
first calibration (offsets through their exact integer parts, gains as ratios
minus 1, temperatures about their mean), never an absolute of 48,000 nT or of
millions of codes. The warm-up's temperatures are integer centidegrees, its
sums exact integers, the drift enters them in fixed point.

Assumptions (refused where they can be checked): one sensor, one site (a
changed field reads as a common gain), the same input unit, a temperature that
moved by MIN_SPAN_C or more. A quick re-calibration (shape from the previous
one) carries the offsets and the common gain only; per-axis gains need full
calibrations.
"""

import math

from shared.calibration import Calibration
from shared.codes import TOO_FEW_SAMPLES
from shared.fit import EllipsoidFit, FitError
from shared.moments import COUNT, INDEX, ORDER, bit_length

MIN_SPAN_C = 2.0        # a line through less is noise
MAX_GAIN_STEP = 0.05    # gains that differ by more between records: another unit or sensor
MICRO_N = 64            # warm-up: samples in a micro-block (one temperature for all of them)
MICRO_C = 0.02          # or the temperature change that closes one sooner
_FIX = 40               # fixed-point bits of the drift coefficients in moved_sums
# a full-sphere fit's predicted error is FULL_SPHERE_K rms / sqrt(n) (measured: 3.0 at 1,000 and 4,000
# samples; a half sphere gives 12, 30 % 45, 10 % 530): WarmupFit's yardstick for a segment's coverage
FULL_SPHERE_K = 3.0
FRAME_BITS = 34         # moved sums: the samples' spread scaled to ~2^34 (the solver's frame takes 2^40)


def _gain_ratio(cal, ref):
    """(3,) gain of each raw axis of cal relative to ref, minus 1: sqrt(A_ref,ii / A_ii) - 1."""
    f = cal.field / ref.field
    out = []
    for i in range(3):
        a = cal.matrix[0][i] ** 2 + cal.matrix[1][i] ** 2 + cal.matrix[2][i] ** 2
        a_ref = ref.matrix[0][i] ** 2 + ref.matrix[1][i] ** 2 + ref.matrix[2][i] ** 2
        q = (a_ref / a) * f * f
        out.append((q - 1.0) / (math.sqrt(q) + 1.0))   # sqrt(q) - 1 without cancelling
    return out


def _offset_step(cal, ref):
    """(3,) cal's offset minus ref's: integer parts in integers, then the fractions."""
    return [(cal._b_int[i] - ref._b_int[i]) + (cal._b_frac[i] - ref._b_frac[i]) for i in range(3)]


def _lines(ts, ys, ws):
    """Weighted least-squares lines y_k = c + s (t - tm) of columns ys[k][0..2] against ts;
    returns (tm, [c0, c1, c2], [s0, s1, s2])."""
    sw = 0.0
    for w in ws:
        sw += w
    tm = 0.0
    for t, w in zip(ts, ws):
        tm += w * t
    tm /= sw
    stt = 0.0
    for t, w in zip(ts, ws):
        stt += w * (t - tm) * (t - tm)
    cs = []
    ss = []
    for i in range(3):
        ym = 0.0
        sty = 0.0
        for t, y, w in zip(ts, ys, ws):
            ym += w * y[i]
            sty += w * (t - tm) * y[i]
        cs.append(ym / sw)
        ss.append(sty / stt)
    return tm, cs, ss


def _span_check(temps, what):
    lo = min(temps)
    hi = max(temps)
    distinct = []
    for t in temps:
        if t not in distinct:
            distinct.append(t)
    if len(distinct) < 2 or hi - lo < MIN_SPAN_C:
        raise ValueError("%s span %.2f C (%d distinct temperatures): temperature coefficients need two or more"
                         " temperatures at least %.1f C apart" % (what, hi - lo, len(distinct), MIN_SPAN_C))
    return lo, hi


def _tempco(tm, b_lines, g_lines, t0, lo, hi, sources, method):
    """The record from lines of offset steps and gain ratios about tm, referred to t0."""
    o = b_lines[1]
    g = []
    for i in range(3):
        r0 = g_lines[0][i] + g_lines[1][i] * (t0 - tm)    # gain ratio - 1 at t0
        g.append(g_lines[1][i] / (1.0 + r0))              # relative to the gain at t0
    return {"t0_c": t0, "offset_per_c": o, "gain_per_c": g, "range_c": [lo, hi], "sources": sources,
            "method": method}


def fit_tempco(cals, t0_c=None, weights=None):
    """The tempco record from two or more calibrations of one sensor at one site.

    cals: Calibrations (full or quick) with meta["temperature_c"], in one input unit.
    t0_c: the reference temperature; default the last calibration's (the record the
        coefficients will be attached to; attach() re-refers them to any other).
    weights: one per calibration for the lines (default equal).
    Refuses (ValueError) fewer than two temperatures, a span under MIN_SPAN_C, a
    missing temperature, mixed units and gains that differ by more than 5 %.
    """
    if len(cals) < 2:
        raise ValueError("temperature coefficients need two or more calibrations, got %d" % len(cals))
    temps = []
    units = cals[0].meta.get("units")
    for k, c in enumerate(cals):
        t = c.meta.get("temperature_c")
        if t is None:
            raise ValueError("calibration %d has no meta.temperature_c" % k)
        if c.meta.get("units") != units:
            raise ValueError("calibration %d is in %r, calibration 0 in %r: one input unit"
                             % (k, c.meta.get("units"), units))
        temps.append(float(t))
    lo, hi = _span_check(temps, "the calibrations'")
    ref = cals[0]
    gs = []
    bs = []
    for k, c in enumerate(cals):
        r = _gain_ratio(c, ref)
        for i in range(3):
            if abs(r[i]) > MAX_GAIN_STEP:
                raise ValueError("calibration %d's axis %d gain differs by %.3g from calibration 0's:"
                                 " not the same sensor, unit or site" % (k, i, r[i]))
        gs.append(r)
        bs.append(_offset_step(c, ref))
    ws = [1.0] * len(cals) if weights is None else [float(w) for w in weights]
    t0 = temps[-1] if t0_c is None else float(t0_c)
    tm, bc, bsl = _lines(temps, bs, ws)
    _, gc, gsl = _lines(temps, gs, ws)
    return _tempco(tm, (bc, bsl), (gc, gsl), t0, lo, hi, len(cals), "calibrations")


def attach(cal, tempco):
    """A copy of cal carrying tempco, referred to cal's own meta["temperature_c"] (the
    temperature its matrix and offset are for). Offsets' slopes do not change; a gain
    coefficient g about t0 is g / (1 + g (t1 - t0)) about t1."""
    t1 = cal.meta.get("temperature_c")
    if t1 is None:
        raise ValueError("the calibration has no meta.temperature_c to refer the coefficients to")
    tc = dict(tempco)
    d = float(t1) - tc["t0_c"]
    tc["gain_per_c"] = [g / (1.0 + g * d) for g in tc["gain_per_c"]]
    tc["t0_c"] = float(t1)
    return Calibration(cal.matrix, cal.offset, cal.field, cal.diagnostics, cal.meta, tc)


class _Segment:
    """One temperature segment of a warm-up: the exact power sums of its samples (in an
    EllipsoidFit) and of its samples times q, q^2, q^3, q^4 (sp; q the temperature in
    centidegrees from WarmupFit.t_ref, one q per micro-block: its mean)."""

    def __init__(self, start):
        self.fit = EllipsoidFit()
        self.sp = [[0] * COUNT, [0] * COUNT, [0] * COUNT, [0] * COUNT]
        self.start = start       # C, the temperature that opened it
        self.lo = start
        self.hi = start

    def absorb(self, other):
        self.fit.merge(other.fit)
        for j in range(4):
            a = self.sp[j]
            b = other.sp[j]
            for k in range(COUNT):
                a[k] += b[k]
        self.lo = min(self.lo, other.lo)
        self.hi = max(self.hi, other.hi)

    def copy(self):
        c = _Segment(self.start)
        c.absorb(self)
        return c

    def fold(self, micro, mq):
        """Add a micro-block: an EllipsoidFit and the sum of its samples' centidegrees."""
        n = micro.n
        if not n:
            return
        q = (2 * mq + n) // (2 * n)      # its mean temperature, nearest centidegree
        sums = micro.sums()
        self.fit.merge(micro)
        if not q:
            return
        s1, s2, s3, s4 = self.sp
        q2 = q * q
        q3 = q2 * q
        q4 = q2 * q2
        for k in range(COUNT):
            v = sums[k]
            s1[k] += q * v
            s2[k] += q2 * v
            s3[k] += q3 * v
            s4[k] += q4 * v

    def powers(self):
        """[S0, S1, S2, S3, S4]: sum q^j m for every monomial m (storage order)."""
        return [self.fit.sums()] + [list(r) for r in self.sp]


_BINOM = ((1,), (1, 1), (1, 2, 1), (1, 3, 3, 1), (1, 4, 6, 4, 1))


def _recentre(sp, delta):
    """[S0..S4] about q = delta (integer centidegrees) from [S0..S4] about q = 0, exactly:
    sum (q - delta)^j m = sum_u C(j, u) (-delta)^(j-u) S_u."""
    if not delta:
        return sp
    out = []
    for j in range(5):
        row = [0] * COUNT
        for u in range(j + 1):
            c = _BINOM[j][u] * (-delta) ** (j - u)
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
        polys.append([[[_BINOM[e][t] * v for v in _pmul(pa[t], pb[e - t])] for t in range(e + 1)]
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


def _frame_bits(s0):
    """Fractional bits for moved sums: the samples' rms spread times 2^bits about 2^FRAME_BITS."""
    n = s0[0]
    tr = 0
    for e1, e2 in (((1, 0, 0), (2, 0, 0)), ((0, 1, 0), (0, 2, 0)), ((0, 0, 1), (0, 0, 2))):
        tr += n * s0[INDEX[e2]] - s0[INDEX[e1]] * s0[INDEX[e1]]
    spread = (bit_length(tr // (n * n)) + 1) // 2
    return max(0, FRAME_BITS - spread)


def _in_frame(cal, centre, bits):
    """cal for inputs 2^bits (h - centre)."""
    m = [[math.ldexp(v, -bits) for v in row] for row in cal.matrix]
    b = [math.ldexp((cal._b_int[i] - centre[i]) + cal._b_frac[i], bits) for i in range(3)]
    return Calibration(m, b, cal.field, cal.diagnostics, cal.meta)


def _out_of_frame(cal, centre, bits):
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


def _solve_moved(sp, lines, offset, prior, field, scale, solve_kw):
    """A full fit (prior None) or a quick one of the sums sp moved with lines = (o, g)
    about offset (None: not moved)."""
    if lines is None:
        return _solve_sums(sp[0], field=field, scale=scale, prior=prior, **solve_kw)
    centre = [int(math.floor(v + 0.5)) for v in offset]
    bits = _frame_bits(sp[0])
    sums = moved_sums(sp, lines[0], lines[1], offset, centre, bits)
    if isinstance(scale, (int, float)):
        sc = math.ldexp(scale, -bits)
    else:
        sc = [math.ldexp(v, -bits) for v in scale]
    pr = None if prior is None else _in_frame(prior, centre, bits)
    return _out_of_frame(_solve_sums(sums, field=field, scale=sc, prior=pr, **solve_kw), centre, bits)


def _fixed(v):
    return int(math.floor(math.ldexp(v, _FIX) + 0.5))


def _solve_sums(sums, **kw):
    """EllipsoidFit.solve on given power sums (its whole state: the 35 sums, packs empty)."""
    return EllipsoidFit.from_sums(sums).solve(**kw)


class WarmupFit:
    """Temperature coefficients from one long calibration while the temperature moves.

    The samples go into one EllipsoidFit per temperature segment. A new segment
    opens when the temperature has moved `width_c` from the one that opened the
    current segment; with more than `max_segments`, neighbours merge in pairs
    (oldest first: exact) and the width doubles. So whatever the final span
    (unknown while the temperature moves), 2 to max_segments segments of about
    equal width remain, the last one still filling. The temperature need not
    move monotonically: a sample joins the current segment until it is width_c
    from that segment's start.

    Why more than one accumulator per segment: while the temperature moves, the
    gain drifts (2 nT/C at 40 ppm/C) and the hand visits directions unevenly in
    time, so a plain fit over a span of temperatures is biased by the drift
    (measured: 0.8 nT peak to peak over a spin after 4 C in 150 s, against a
    0.24 nT floor). Each segment also keeps sum q^j m for j = 1..4 (q its
    temperature, m every monomial), exact integers, so its sums can be moved to
    any temperature exactly for a given drift (moved_sums): solve() iterates
    from no drift. The samples enter those sums in micro-blocks of MICRO_N
    samples or MICRO_C (one product per monomial per block, not per sample),
    each at its mean temperature.
    Memory: max_segments + 2 accumulators and 140 integers per segment.
    """

    def __init__(self, width_c=0.5, max_segments=4):
        if max_segments < 2 or not width_c > 0:
            raise ValueError("WarmupFit needs max_segments >= 2 and a positive width_c")
        self.width = float(width_c)
        self.max_segments = max_segments
        self.segs = []
        self.t_ref = None       # first temperature: centidegrees are counted from it
        self._micro = EllipsoidFit()
        self._mq = 0            # centidegrees summed over the micro-block
        self._mstart = 0.0
        self.segments = []      # after solve: what each segment gave

    @property
    def n(self):
        s = self._micro.n
        for g in self.segs:
            s += g.fit.n
        return s

    def add(self, x, y, z, temp_c):
        segs = self.segs
        if self.t_ref is None:
            self.t_ref = temp_c
        if not segs or abs(temp_c - segs[-1].start) >= self.width:
            if segs:
                self._flush()
            segs.append(_Segment(temp_c))
            if len(segs) > self.max_segments:
                self._coarsen()
        elif self._micro.n >= MICRO_N or abs(temp_c - self._mstart) >= MICRO_C:
            self._flush()
        micro = self._micro
        if not micro.n:
            self._mstart = temp_c
        micro.add(x, y, z)
        self._mq += int(math.floor((temp_c - self.t_ref) * 100.0 + 0.5))
        s = self.segs[-1]
        if temp_c < s.lo:
            s.lo = temp_c
        elif temp_c > s.hi:
            s.hi = temp_c

    def _flush(self):
        self.segs[-1].fold(self._micro, self._mq)
        self._micro = EllipsoidFit()
        self._mq = 0

    def _coarsen(self):
        segs = self.segs
        out = []
        for i in range(0, len(segs) - 1, 2):
            segs[i].absorb(segs[i + 1])
            out.append(segs[i])
        if len(segs) % 2:
            out.append(segs[-1])
        self.segs = out
        self.width *= 2.0

    def solve(self, field=None, scale=1.0, full_factor=4.0, min_fraction=0.25, iterations=3, **solve_kw):
        """The calibration at the mean temperature of all samples, carrying its tempco.

        Each round: the whole (every segment merged, its sums moved to the mean
        temperature with the coefficients so far; none in the first round) is
        fitted in full; then each segment with its sums moved to its own mean
        temperature: a full fit when its predicted error is within full_factor
        of what its sample count alone allows (the whole's predicted error times
        sqrt(N / n)), else a quick re-calibration with the whole as prior
        (offsets and common gain). A segment under min_fraction of the mean
        sample count is merged into its neighbour first. Offsets' lines use every
        segment; per-axis gains the full ones when two or more span MIN_SPAN_C,
        else every segment's mean gain (tempco["gains"] "common"). `segments`
        lists what each gave in the last round. FitError from the whole's fit;
        ValueError when the temperature moved less than MIN_SPAN_C or fewer than
        two segments solve. Adding may go on afterwards.
        """
        segs = self._usable(min_fraction)
        if not segs:
            raise FitError(TOO_FEW_SAMPLES, "no samples")
        lo = segs[0].lo
        hi = segs[0].hi
        for s in segs:
            lo = min(lo, s.lo)
            hi = max(hi, s.hi)
        if hi - lo < MIN_SPAN_C:
            raise ValueError("the temperature moved %.2f C during the calibration: temperature coefficients"
                             " need %.1f C or more" % (hi - lo, MIN_SPAN_C))
        whole = [[0] * COUNT for _ in range(5)]
        parts = []
        for s in segs:
            sp = s.powers()
            for j in range(5):
                for k in range(COUNT):
                    whole[j][k] += sp[j][k]
            d = (2 * sp[1][0] + sp[0][0]) // (2 * sp[0][0])       # mean, nearest centidegree
            parts.append((_recentre(sp, d), self.t_ref + d / 100.0))
        n_all = whole[0][0]
        d0 = (2 * whole[1][0] + n_all) // (2 * n_all)
        whole = _recentre(whole, d0)
        t0 = self.t_ref + d0 / 100.0
        lines = None
        offsets = [None] * len(parts)
        cal = None
        for _ in range(max(1, iterations)):
            cal = _solve_moved(whole, lines, cal.offset if cal else None, None, field, scale, solve_kw)
            self.segments = []
            temps = []
            gs = []
            bs = []
            ws = []
            full = []
            for j in range(len(parts)):
                sp, t_s = parts[j]
                # moved about its own offset, or the whole's until it has one (only g b enters); a
                # quick fit's prior is the whole drifted to the segment's temperature by the lines
                prior = cal if lines is None else cal._drifted(lines[0], lines[1], t_s - t0)
                c, kind = _solve_segment(sp, lines, offsets[j] or cal.offset, prior, field, scale, full_factor,
                                         solve_kw)
                self.segments.append({"temperature_c": t_s, "n": sp[0][0], "kind": kind})
                if c is None:
                    continue
                offsets[j] = c.offset
                temps.append(t_s)
                gs.append(_gain_ratio(c, cal))
                bs.append(_offset_step(c, cal))
                ws.append(float(sp[0][0]))
                full.append(kind == "full")
            if len(temps) < 2:
                raise ValueError("%d of %d temperature segments solved: temperature coefficients need two"
                                 % (len(temps), len(parts)))
            tm, bc, bsl = _lines(temps, bs, ws)
            ft = [t for t, f in zip(temps, full) if f]
            per_axis = len(ft) >= 2 and max(ft) - min(ft) >= MIN_SPAN_C
            if per_axis:
                gm, gc, gsl = _lines(ft, [g for g, f in zip(gs, full) if f], [w for w, f in zip(ws, full) if f])
            else:
                gm, gc, gsl = _lines(temps, [[(g[0] + g[1] + g[2]) / 3.0] * 3 for g in gs], ws)
            # the gain lines about the offsets' mean temperature
            gc = [gc[i] + gsl[i] * (tm - gm) for i in range(3)]
            tc = _tempco(tm, (bc, bsl), (gc, gsl), t0, lo, hi, len(temps), "warmup")
            lines = (tc["offset_per_c"], tc["gain_per_c"])
        tc["gains"] = "per_axis" if per_axis else "common"
        tc["full_segments"] = len(ft)
        meta = dict(cal.meta)
        meta["temperature_c"] = t0
        return Calibration(cal.matrix, cal.offset, cal.field, cal.diagnostics, meta, tc)

    def _usable(self, min_fraction):
        """Copies of the segments (the open micro-block folded into the last), a small one
        merged into its neighbour: the accumulators stay as they are."""
        segs = []
        for s in self.segs:
            segs.append(s.copy())
        if segs:
            segs[-1].fold(self._micro, self._mq)
        out = []
        for s in segs:
            if s.fit.n:
                out.append(s)
        if len(out) < 2:
            return out
        mean = self.n / len(out)
        i = 0
        while i < len(out) and len(out) > 2:
            if out[i].fit.n < min_fraction * mean:
                j = i - 1 if i > 0 else i + 1
                out[j].absorb(out[i])
                del out[i]
            else:
                i += 1
        return out


def _solve_segment(sp, lines, offset, prior, field, scale, full_factor, solve_kw):
    """(Calibration, "full") when the segment's coverage allows its own fit (its predicted
    error within full_factor of a full sphere's for its samples and residual), else
    (Calibration, "quick"): a quick re-calibration with `prior` (shared/quick.py), else
    (None, "kept") when that finds nothing better than the prior, or (None, "failed")."""
    n = sp[0][0]
    try:
        c = _solve_moved(sp, lines, offset, None, field, scale, solve_kw)
        pe = c.diagnostics.get("predicted_error")
        rms = c.diagnostics.get("rms")
        if pe is not None and rms is not None and pe <= full_factor * FULL_SPHERE_K * rms / math.sqrt(n):
            return c, "full"
    except FitError:
        pass
    try:
        return _solve_moved(sp, lines, offset, prior, field, scale, solve_kw), "quick"
    except FitError as e:
        return None, "kept" if e.reason == "not_better" else "failed"
