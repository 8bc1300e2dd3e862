"""Temperature coefficients from one long calibration while the temperature moves.

    from shared.warmup import WarmupFit
    w = WarmupFit()                         # one long calibration while the temperature moves
    w.add(x, y, z, temp_c)                  # integers as EllipsoidFit.add, and the temperature
    cal = w.solve(scale=k)                  # the calibration at the mean temperature, with .tempco
    w.segments                              # what each temperature segment gave (its "kind")

The warm-up (WarmupFit): temperature segments, each an exact accumulator plus
the sums of its monomials times powers of the temperature, so that its samples
can be moved to one temperature before they are fitted (moved_sums): without
that, the drift during a segment biases its fit (docs/temperature.md). Each
segment is fitted in full when its coverage allows (kind "full"), else as a
quick re-calibration on the whole's shape drifted to its temperature ("quick";
"kept" when that finds nothing better than the prediction, "failed" when it
fails); per-axis gains come from full segments only.

The temperatures are integer centidegrees, the sums exact integers, the drift
enters them in fixed point (shared/moved.py). The model and the record:
shared/tempco.py. The firmware does not run this (30.8 KB of sums on 32-bit):
it is not shipped to the board (device/manifest.py).
"""

import math

from shared.calibration import Calibration
from shared.codes import TOO_FEW_SAMPLES
from shared.fit import EllipsoidFit, FitError
from shared.moments import COUNT
from shared.moved import recentre, solve_moved
from shared.tempco import MIN_SPAN_C, gain_ratio, offset_step, tempco_record, weighted_lines

MICRO_N = 64            # warm-up: samples in a micro-block (one temperature for all of them)
MICRO_C = 0.02          # or the temperature change that closes one sooner
# a full-sphere fit's predicted error is FULL_SPHERE_K rms / sqrt(n) (measured: 3.0 at 1,000 and 4,000
# samples; a half sphere gives 12, 30 % 45, 10 % 530): WarmupFit's yardstick for a segment's coverage
FULL_SPHERE_K = 3.0


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
            parts.append((recentre(sp, d), self.t_ref + d / 100.0))
        n_all = whole[0][0]
        d0 = (2 * whole[1][0] + n_all) // (2 * n_all)
        whole = recentre(whole, d0)
        t0 = self.t_ref + d0 / 100.0
        lines = None
        offsets = [None] * len(parts)
        cal = None
        for _ in range(max(1, iterations)):
            cal = solve_moved(whole, lines, cal.offset if cal else None, None, field, scale, solve_kw)
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
                gs.append(gain_ratio(c, cal))
                bs.append(offset_step(c, cal))
                ws.append(float(sp[0][0]))
                full.append(kind == "full")
            if len(temps) < 2:
                raise ValueError("%d of %d temperature segments solved: temperature coefficients need two"
                                 % (len(temps), len(parts)))
            tm, bc, bsl = weighted_lines(temps, bs, ws)
            ft = [t for t, f in zip(temps, full) if f]
            per_axis = len(ft) >= 2 and max(ft) - min(ft) >= MIN_SPAN_C
            if per_axis:
                gm, gc, gsl = weighted_lines(ft, [g for g, f in zip(gs, full) if f], [w for w, f in zip(ws, full) if f])
            else:
                gm, gc, gsl = weighted_lines(temps, [[(g[0] + g[1] + g[2]) / 3.0] * 3 for g in gs], ws)
            # the gain lines about the offsets' mean temperature
            gc = [gc[i] + gsl[i] * (tm - gm) for i in range(3)]
            tc = tempco_record(tm, (bc, bsl), (gc, gsl), t0, lo, hi, len(temps), "warmup")
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
        c = solve_moved(sp, lines, offset, None, field, scale, solve_kw)
        pe = c.diagnostics.get("predicted_error")
        rms = c.diagnostics.get("rms")
        if pe is not None and rms is not None and pe <= full_factor * FULL_SPHERE_K * rms / math.sqrt(n):
            return c, "full"
    except FitError:
        pass
    try:
        return solve_moved(sp, lines, offset, prior, field, scale, solve_kw), "quick"
    except FitError as e:
        return None, "kept" if e.reason == "not_better" else "failed"
