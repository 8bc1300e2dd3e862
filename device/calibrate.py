"""The one-button in-field calibration: gate samples, fit, check, accept or refuse.

    s = Session(cfg, scale, window, period_ms, prior=None, now_ms=0, kind="auto")
    s.sample(sx, sy, sz)           # each decimated sample (integer boxcar sums)
    s.tick(now_ms)                 # provisional solve every solve_every_s
    s.ready()                      # coverage and predicted error reached
    cal, reason, msg = s.finish()  # cal in ADC-code units, or (None, reason, msg)

Gates, in order (each rejection is counted and reported). They work on the
sums shifted down to ~14 bits (`_sh`, full scale < 2**14), so every product
below stays a small int (< 2**30: no heap allocation on MicroPython, where a
float op or a bigger int allocates) and the cell index is cheap; 14 bits put
one step at ~0.01 degree of direction, far below the ~20 degree cells and the
gate's ~7 degree turn per sample.
1. rotation rate: the chord |v_k - v_(k-s)| (offset free) over |v - c| and s
   sample periods gives the turn rate; above the gate the sample is dropped.
   The gate is the lower of gate_rate_dps (the boxcar smears |B|: shrink
   ~ (w T)^2 / 24) and what the sensor's own bandwidth allows: a first-order
   low-pass of time constant tau = 1 / (2 pi sensor_bandwidth_hz) reads
   |B| (1 - (tau w)^2 / 2) while turning at w (docs/experiments.md, lag), so
   w <= sqrt(2 lag_tol_nt / B) / tau: 720 deg/s for a 1 kHz Mag649 (the
   360 deg/s gate stands), 8 deg/s for a 5 Hz Mag648. The stride s spans
   enough samples that the allowed turn is a few 14-bit steps. The gate works
   in codes: exact for equal scale_x/y/z, tilted by their ratio otherwise.
2. coverage cap: 6*cells^2 equal-area cells about the centre (the previous
   calibration's offset, else the front end's zero: raw offsets are < 2 % of
   |B|, a direction error of ~1 degree against ~20 degree cells); a full
   cell takes no more, so slow lingering in one pose does not dominate. Checked
   before the disturbance gate: a sample a full cell rejects costs no float.
3. disturbance: once a provisional fit exists, a sample in a cell that holds
   >= 3 samples whose calibrated |B| departs from the fitted field by more
   than max(outlier_nt, 4 rms + 2 predicted error) is dropped; three in a row
   make a disturbance, and the samples accepted in the second before it are
   removed from the fit again (fit.remove is exact), and every sample is
   rejected until |B| has stayed within a tenth of the gate for a second
   (the dipole's 1/r^3 tail, tests/test_device_calibration.py).

Kinds (start-cal quick|full|auto, docs/protocol.md): a full calibration fits
all nine parameters; a quick re-calibration (shared/quick.py) keeps the shape
of the calibration in force and fits its offsets and common gain from a
partial rotation, auto-finishing at quick_min_coverage; auto (the button's
short press) decides at the end: quick when a calibration is in force and the
coverage stayed under min_coverage, else full.

The fit runs on the full boxcar sums (units: code/window; exact integers:
EllipsoidFit.add costs the same ~25 us on the unix port for 17- to 24-bit
inputs, so shifting them would buy nothing); the accepted calibration is
rescaled to ADC codes so it survives a change of window.
"""

import math
from array import array

from shared.fit import EllipsoidFit, FitError
from shared.coverage import Coverage

FULL = "full"
QUICK = "quick"
RESHAPED = "reshaped"     # a quick session whose data said the shape moved (shared/quick.py)
AUTO = "auto"
KINDS = (AUTO, FULL, QUICK)

COLLECTING = "collecting"
DONE = "done"
FAILED = "failed"
CANCELLED = "cancelled"

_HIST = 256          # recent accepted samples kept for removal (5 ints each)
_MIN_PROVISIONAL = 60
_RUN = 3             # consecutive outliers that make a disturbance
# Gauss-Newton steps of a provisional solve. It only sets the disturbance gate and
# says when coverage is enough; from the algebraic fit one step lands within 5e-5 nT
# of the converged fit on a 40 % cap (identical with full coverage), and each further
# step costs ~4M instructions on a Cortex-M (docs/firmware.md). The final solve converges.
_PROVISIONAL_ITER = 1
_GATE_BITS = 14      # gate/cell arithmetic: |v| < 2**14, so |v|^2 sums stay < 2**30
_G_SHIFT = 16        # rate gate: d^2 > (r^2 >> 16) * round(angle^2 * 2**16)
_MAX_STRIDE = 64     # rate gate baseline, samples (0.64 s at 100 samples/s)
_MIN_PAIRS = 50      # consecutive residual pairs before their correlation counts
_MAX_RHO = 0.999     # widening at most sqrt(1999) ~ 45x


def gate_dps(cfg):
    """The rotation-rate gate: gate_rate_dps, or lower where the sensor's bandwidth lags."""
    tau = 1.0 / (2.0 * math.pi * cfg["sensor_bandwidth_hz"])
    field = cfg["field_nt"] or 50000.0
    lag = math.sqrt(2.0 * cfg["lag_tol_nt"] / field) / tau * 180.0 / math.pi
    return min(cfg["gate_rate_dps"], lag)


class Session:
    def __init__(self, cfg, scale, window, period_ms, prior=None, now_ms=0, kind="auto"):
        self.cfg = cfg
        self.kind = kind if prior is not None else FULL   # no calibration in force: only a full one
        self.window = window
        # nT per sum unit, per axis
        self.k = (scale[0] / window, scale[1] / window, scale[2] / window)
        self.period_ms = period_ms
        self.prior = prior.scaled_input(window) if prior is not None else None
        self.fit = EllipsoidFit()
        self.cov = Coverage(cfg["cells"], cfg["cell_cap"])
        if self.prior is not None:
            self.c = [int(v) for v in self.prior.offset]
        else:
            self.c = [0, 0, 0]
        # shift that brings a full-scale sum (window * 2**23 codes) below 2**14
        sh = 0
        while (window << 23) >> sh >= (1 << _GATE_BITS):
            sh += 1
        self._sh = sh
        self._cx = self.c[0] >> sh
        self._cy = self.c[1] >> sh
        self._cz = self.c[2] >> sh
        self.state = COLLECTING
        self.started = now_ms
        self.seen = 0
        self.rej_rate = 0
        self.rej_dist = 0
        self.rej_cap = 0
        self.removed = 0
        self.provisional = None
        self.provisional_error = None
        self.solves = 0             # provisional solves run
        self.last_solve = now_ms
        self._solve_ms = cfg["solve_every_s"] * 1000
        self._max_ms = cfg["max_cal_s"] * 1000
        self._cap = cfg["cell_cap"]
        self._dist_limit = cfg["outlier_nt"]
        self.reason = None
        self.message = None
        self.temp_sum = 0.0
        self.temp_n = 0
        self.clipped = 0            # samples at the ADC's full scale (screen.py; not fitted)
        self.clip_axis = None
        self._fresh = True          # no previous sample to compare with
        self._dist_run = 0
        self._hold = 0              # samples still to reject after a disturbance
        self._hist = array("i", bytes(4 * 5 * _HIST))  # x, y, z, sample index, cell
        self._hn = 0
        self._hi = 0
        self._back = int(1000 / period_ms) + 1   # samples in one second (backoff)
        self.gate_dps = gate_dps(cfg)
        g = self.gate_dps * math.pi / 180.0 * period_ms / 1000.0
        # compare with the sample `stride` back, so the allowed turn is >= 1/64 rad: a few
        # steps of the 14-bit vectors (a slow sensor's gate is ~1e-3 rad per sample)
        stride = 1
        while g * stride < 0.016 and stride < _MAX_STRIDE:
            stride += 1
        self._stride = stride
        self._ring = array("i", bytes(4 * 3 * stride))   # the last `stride` shifted samples
        self._ri = 0
        self._filled = 0
        g = g * stride
        self._g = max(1, int(g * g * (1 << _G_SHIFT) + 0.5))   # max squared turn angle per stride
        self._fast_mark = 0          # rej_rate / seen at the last progress report
        self._seen_mark = 0
        self.slow_down = False       # most samples of the last report turned too fast

    def elapsed_s(self, now_ms, diff):
        return diff(now_ms, self.started) / 1000.0

    def timed_out(self, now_ms, diff):
        return diff(now_ms, self.started) > self._max_ms

    def break_chain(self):
        """Samples were lost: the next one has no neighbour to gate its turn rate against."""
        self._fresh = True

    def sample(self, sx, sy, sz):
        """Gate one decimated sample; return True if it went into the fit."""
        self.seen += 1
        sh = self._sh
        x = (sx >> sh) - self._cx
        y = (sy >> sh) - self._cy
        z = (sz >> sh) - self._cz
        if self._fresh:
            self._fresh = False
            self._filled = 0
        r = self._ring
        i = self._ri * 3
        dx = x - r[i]
        dy = y - r[i + 1]
        dz = z - r[i + 2]
        r[i] = x
        r[i + 1] = y
        r[i + 2] = z
        self._ri = (self._ri + 1) % self._stride
        if self._filled < self._stride:
            self._filled += 1
            return False
        # 1. rotation rate: chord^2 > angle^2 |r|^2, in small ints
        if dx * dx + dy * dy + dz * dz > ((x * x + y * y + z * z) >> _G_SHIFT) * self._g:
            self.rej_rate += 1
            return False
        if not (x or y or z):
            self.rej_rate += 1   # no direction (a dead front end): nothing to place
            return False
        # 2. coverage cell cap
        cov = self.cov
        cell = cov.cell(x, y, z)
        n = cov.count(cell)
        if n >= self._cap:
            self.rej_cap += 1
            return False
        # 3. disturbance, against the provisional fit, only where it interpolates:
        # in a cell that already holds samples, and once its predicted error is
        # well below the gate. A new orientation is never called a disturbance.
        pc = self.provisional
        if pc is not None and (n >= 3 or self._hold):
            dev = abs(pc.magnitude(sx, sy, sz) - pc.field)
            if dev > self._dist_limit:
                self.rej_dist += 1
                self._dist_run += 1
                if self._dist_run == _RUN:
                    self._backoff()   # a disturbance, not a lone outlier: its onset went in
                    self._hold = self._back
                return False
            self._dist_run = 0
            if self._hold:
                # back-off: a dipole's 1/r^3 tail stays above the noise long after it
                # falls under the gate; hold until it is under a tenth of the gate for 1 s
                self.rej_dist += 1
                if dev > 0.1 * self._dist_limit:
                    self._hold = self._back
                else:
                    self._hold -= 1
                return False
        self.fit.add(sx, sy, sz)
        cov.add_to(cell)
        h = self._hist
        i = self._hi * 5
        h[i] = sx
        h[i + 1] = sy
        h[i + 2] = sz
        h[i + 3] = self.seen
        h[i + 4] = cell
        self._hi = (self._hi + 1) % _HIST
        if self._hn < _HIST:
            self._hn += 1
        return True

    def _backoff(self):
        """Remove samples accepted in the second before a disturbance was detected."""
        h = self._hist
        back = self._back
        while self._hn:
            j = (self._hi - 1) % _HIST
            i = j * 5
            if self.seen - h[i + 3] > back:
                break
            self.fit.remove(h[i], h[i + 1], h[i + 2])
            self.cov.remove_from(h[i + 4])
            self._hi = j
            self._hn -= 1
            self.removed += 1

    def residual_rho(self, cal):
        """Lag-1 correlation of the residuals |h_c| - F of consecutive accepted samples among
        the last _HIST (the removal history), against the final fit; None with too few pairs.

        The fit's predicted error assumes independent residuals. A sensor that lags the
        turn (a bandwidth set too high for it), a field that wanders or a flexing mount
        leave residuals that follow each other from sample to sample; with their lag-1
        correlation rho (AR(1)) the samples count as N (1 - rho) / (1 + rho), and finish()
        widens the predicted error by sqrt((1 + rho) / (1 - rho)). Against the final fit,
        not a provisional one: a provisional fit's own error, smooth in orientation, would
        read as correlation when the turn is slow.
        """
        h = self._hist
        n = self._hn
        first = (self._hi - n) % _HIST
        prev_i = -2
        prev_r = 0.0
        pairs = 0
        s = ss = s1 = 0.0
        for k in range(n):
            j = ((first + k) % _HIST) * 5
            r = cal.magnitude(h[j], h[j + 1], h[j + 2]) - cal.field
            i = h[j + 3]
            if i == prev_i + 1:
                pairs += 1
                s += r + prev_r
                ss += r * r + prev_r * prev_r
                s1 += r * prev_r
            prev_i = i
            prev_r = r
        if pairs < _MIN_PAIRS:
            return None, pairs
        m = s / (2 * pairs)
        var = ss / (2 * pairs) - m * m
        if not var > 0.0:
            return None, pairs
        return (s1 / pairs - m * m) / var, pairs

    def add_temperature(self, celsius):
        self.temp_sum += celsius
        self.temp_n += 1

    def quick(self):
        """True if this session ends in a quick re-calibration (so far)."""
        if self.kind == QUICK:
            return True
        return self.kind == AUTO and self.coverage() < self.cfg["min_coverage"]

    def _solve(self, max_iter=60, final=False, independent=1.0):
        # provisional solves of an auto session are full ones: it becomes quick only at the end
        quick = self.kind == QUICK or (final and self.quick())
        return self.fit.solve(field=None, prior=self.prior if quick else None, scale=self.k, max_iter=max_iter,
                              refuse_worse=final, independent=independent)

    def tick(self, now_ms, diff):
        """Provisional solve every solve_every_s; returns True if one ran."""
        if self.fit.n < _MIN_PROVISIONAL:
            return False
        if diff(now_ms, self.last_solve) < self._solve_ms:
            return False
        self.last_solve = now_ms
        self.solves += 1
        try:
            cal = self._solve(_PROVISIONAL_ITER)
        except FitError:
            self.provisional_error = None
            return True
        d = cal.diagnostics
        pe = d.get("predicted_error")
        self.provisional_error = pe
        self._dist_limit = max(self.cfg["outlier_nt"], 4.0 * d.get("rms", 0.0) + 2.0 * (pe or 0.0))
        # gate disturbances only with a fit good to a quarter of the gate
        self.provisional = cal if (pe is not None and pe < 0.25 * self._dist_limit) else None
        return True

    def coverage(self):
        return self.cov.fraction()

    def ready(self):
        pe = self.provisional_error
        need = self.cfg["quick_min_coverage"] if self.kind == QUICK else self.cfg["min_coverage"]
        return self.coverage() >= need and pe is not None and pe <= self.cfg["target_error_nt"]

    def progress(self, report=False):
        """The session's state; report: the once-a-second event, which also decides
        slow_down from the samples since the last one."""
        pe = self.provisional_error
        if report:
            seen = self.seen - self._seen_mark
            self.slow_down = seen > 0 and 2 * (self.rej_rate - self._fast_mark) > seen
            self._fast_mark = self.rej_rate
            self._seen_mark = self.seen
        return {
            "state": self.state,
            "kind": self.kind,
            "gate_dps": round(self.gate_dps, 1),
            "slow_down": self.slow_down,
            "n": self.fit.n,
            "seen": self.seen,
            "coverage": round(self.coverage(), 3),
            "pred_nt": None if pe is None else round(pe, 3),
            "rej_rate": self.rej_rate,
            "rej_dist": self.rej_dist,
            "rej_cap": self.rej_cap,
            "removed": self.removed,
            "clipped": self.clipped,
            "ready": self.ready(),
        }

    def cancel(self):
        self.state = CANCELLED
        self.reason = "cancelled"
        self.message = "cancelled by the operator"

    def finish(self):
        """Solve and check. Returns (cal in code units, None, None) or (None, reason, message)."""
        # Clipping first: the orientations where the ADC saturates are missing from the fit
        # and would be wrong in the survey, whatever the residual says.
        if self.clipped * CLIP_FRACTION > self.seen + self.clipped:
            return self._fail("clipped", "%d samples hit the ADC's full scale%s: lower the PGA gain (gain_x/y/z)"
                              " or keep magnets and iron away; the sensor saturates there"
                              % (self.clipped, "" if self.clip_axis is None else " on " + "xyz"[self.clip_axis]))
        try:
            cal = self._solve(final=True)
            d = cal.diagnostics
            if d.get("mode") == RESHAPED or (d.get("mode") == QUICK and d.get("gains", 1) > 1):
                # a quick one chose a bigger model by likelihood ratios, which correlated
                # residuals inflate: solved again with the samples counted as independent
                # (scaling the ratios down can only keep a smaller model, so the common-gain
                # result stands as it is)
                rho, pairs = self.residual_rho(cal)
                if rho is not None and rho > 2.0 / math.sqrt(pairs):
                    rho = min(rho, _MAX_RHO)
                    cal = self._solve(final=True, independent=(1.0 - rho) / (1.0 + rho))
        except FitError as e:
            return self._fail_fast(e.reason, str(e))
        self._widen(cal)
        problem = self.check(cal)
        if problem:
            return self._fail_fast(problem[0], problem[1])
        self.state = DONE
        code_cal = cal.scaled_input(1.0 / self.window)
        code_cal.diagnostics["coverage"] = round(self.coverage(), 4)
        code_cal.meta["kind"] = cal.diagnostics.get("mode", FULL)
        if self.temp_n:
            code_cal.meta["temperature_c"] = round(self.temp_sum / self.temp_n, 2)
        return code_cal, None, None

    def _widen(self, cal):
        # residuals correlated beyond chance (rho > 2 / sqrt(pairs)): fewer independent samples
        d = cal.diagnostics
        rho, pairs = self.residual_rho(cal)
        if rho is None:
            return
        d["residual_rho"] = round(rho, 4)
        if rho > 2.0 / math.sqrt(pairs) and d.get("predicted_error") is not None:
            rho = min(rho, _MAX_RHO)
            d["predicted_error_white"] = d["predicted_error"]
            d["predicted_error"] = d["predicted_error"] * math.sqrt((1.0 + rho) / (1.0 - rho))

    def _fail_fast(self, reason, message):
        # most samples of a couple of seconds or more turned faster than the gate: that,
        # not the coverage, is the reason (a session finished at once says too_few_samples)
        if self.seen >= 2 * self._back and self.rej_rate * 2 > self.seen and reason != "not_better":
            return self._fail("too_fast", "%d of %d samples turned faster than %.0f deg/s (%s): turn slower"
                              % (self.rej_rate, self.seen, self.gate_dps, message))
        return self._fail(reason, message)

    def _fail(self, reason, message):
        self.state = FAILED
        self.reason = reason
        self.message = message
        return None, reason, message

    def check(self, cal):
        """Acceptance thresholds; (reason, message) for the first that fails, else None."""
        return check_calibration(cal, self.cfg, self.k)


CLIP_FRACTION = 200   # more than 1 in 200 samples clipped refuses the calibration


def _number(d, key):
    # diagnostics may come from a set-cal request: only a number counts
    v = d.get(key)
    return v if isinstance(v, (int, float)) and not isinstance(v, bool) else None


def check_calibration(cal, cfg, k):
    """Physical and statistical sanity of a calibration on inputs of k nT/unit."""
    d = cal.diagnostics
    rms = _number(d, "rms")
    if rms is not None and rms > cfg["max_rms_nt"]:
        return ("rms_too_high", "fit residual %.2f nT > %.2f nT: hold the sensor away from iron and rotate smoothly"
                % (rms, cfg["max_rms_nt"]))
    obs = _number(d, "observability")
    # a quick re-calibration takes its shape from the previous one: a cap is what it is for
    if obs is not None and obs < cfg["min_observability"] and d.get("mode") != QUICK:
        return ("poor_observability", "observability %.3f < %.3f: rotate about all three axes"
                % (obs, cfg["min_observability"]))
    pe = _number(d, "predicted_error")
    if pe is not None and pe > cfg["max_predicted_nt"]:
        rho = _number(d, "residual_rho")
        if rho is not None and rho > 0.5:
            return ("predicted_error_too_high", "predicted error %.2f nT > %.2f nT: the residuals follow each other"
                    " (rho %.2f): the sensor lags the turn (check sensor_bandwidth_hz) or the field moves: turn slower"
                    % (pe, cfg["max_predicted_nt"], rho))
        return ("predicted_error_too_high", "predicted error %.2f nT > %.2f nT: cover more orientations"
                % (pe, cfg["max_predicted_nt"]))
    f0 = cfg["field_nt"]
    if f0:
        if abs(cal.field / f0 - 1.0) > cfg["field_tol"]:
            return ("field_out_of_range", "fitted field %.0f nT, configured %.0f nT +- %.0f %%: check the site or scale_x/y/z"
                    % (cal.field, f0, 100 * cfg["field_tol"]))
    # Gains within 25 % of the configured front end: anything else is a wrong
    # scale setting or a broken channel, not a calibration.
    m = cal.matrix
    for i in range(3):
        g = m[i][i] / k[i]
        if not 0.75 < g < 1.25:
            return ("bad_scale", "axis %s gain %.3f of nominal: check scale_%s and the front end"
                    % ("xyz"[i], g, "xyz"[i]))
    return None
