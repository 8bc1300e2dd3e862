"""The one-button in-field calibration: gate samples, fit, check, accept or refuse.

    s = Session(cfg, scale, window, prior=None, now_ms=0)
    s.sample(sx, sy, sz)           # each decimated sample (integer boxcar sums)
    s.tick(now_ms)                 # provisional solve every solve_every_s
    s.ready()                      # coverage and predicted error reached
    cal, reason, msg = s.finish()  # cal in ADC-code units, or (None, reason, msg)

Gates, in order (each rejection is counted and reported):
1. rotation rate: the chord |v_k - v_(k-1)| (offset free) over |v| and the
   sample period gives the turn rate; above gate_rate_dps the boxcar smears
   |B| (shrink ~ (w T)^2 / 24), so the sample is dropped.
2. disturbance: once a provisional fit exists, a sample in an already visited
   cell whose calibrated |B| departs from the fitted field by more than
   max(outlier_nt, 4 rms + 2 predicted error) is dropped; three in a row make
   a disturbance, and the samples accepted in the second before it are
   removed from the fit again (fit.remove is exact).
3. coverage cap: 6*cells^2 equal-area cells about the centre (the previous
   calibration's offset, else the front end's zero: raw offsets are < 2 % of
   |B|, a direction error of ~1 degree against ~20 degree cells); a full
   cell takes no more, so slow lingering in one pose does not dominate.

The fit runs on the boxcar sums (units: code/window); the accepted calibration
is rescaled to ADC codes so it survives a change of window.
"""

import math
from array import array

from shared.fit import EllipsoidFit, FitError
from shared.coverage import Coverage

COLLECTING = "collecting"
DONE = "done"
FAILED = "failed"
CANCELLED = "cancelled"

_HIST = 256          # recent accepted samples kept for removal (3 ints each)
_MIN_PROVISIONAL = 60
_RUN = 3             # consecutive outliers that make a disturbance


class Session:
    def __init__(self, cfg, scale, window, period_ms, prior=None, now_ms=0):
        self.cfg = cfg
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
        self.state = COLLECTING
        self.started = now_ms
        self.seen = 0
        self.rej_rate = 0
        self.rej_dist = 0
        self.rej_cap = 0
        self.removed = 0
        self.provisional = None
        self.provisional_error = None
        self.last_solve = now_ms
        self.reason = None
        self.message = None
        self.temp_sum = 0.0
        self.temp_n = 0
        self._prev = None
        self._dist_run = 0
        self._hist = array("i", bytes(4 * 4 * _HIST))  # x, y, z, sample index
        self._hn = 0
        self._hi = 0
        g = cfg["gate_rate_dps"] * math.pi / 180.0 * period_ms / 1000.0
        self._gate2 = g * g   # max squared turn angle per sample

    def elapsed_s(self, now_ms, diff):
        return diff(now_ms, self.started) / 1000.0

    def sample(self, sx, sy, sz):
        """Gate one decimated sample; return True if it went into the fit."""
        self.seen += 1
        k = self.k
        prev = self._prev
        self._prev = (sx, sy, sz)
        if prev is None:
            return False
        # 1. rotation rate, in nT so that unequal axis scales do not matter
        dx = (sx - prev[0]) * k[0]
        dy = (sy - prev[1]) * k[1]
        dz = (sz - prev[2]) * k[2]
        c = self.c
        rx = (sx - c[0]) * k[0]
        ry = (sy - c[1]) * k[1]
        rz = (sz - c[2]) * k[2]
        r2 = rx * rx + ry * ry + rz * rz
        if dx * dx + dy * dy + dz * dz > self._gate2 * r2:
            self.rej_rate += 1
            return False
        # 2. disturbance, against the provisional fit, only where it interpolates:
        # in a cell that already holds samples, and once its predicted error is
        # well below the gate. A new orientation is never called a disturbance.
        pc = self.provisional
        if pc is not None and self.cov.counts[self.cov.cell(sx - c[0], sy - c[1], sz - c[2])] >= 3:
            dev = abs(pc.magnitude(sx, sy, sz) - pc.field)
            if dev > self._dist_limit:
                self.rej_dist += 1
                self._dist_run += 1
                if self._dist_run == _RUN:
                    self._backoff()   # a disturbance, not a lone outlier: its onset went in
                return False
            self._dist_run = 0
        # 3. coverage cell cap
        if not self.cov.add(sx - c[0], sy - c[1], sz - c[2]):
            self.rej_cap += 1
            return False
        self.fit.add(sx, sy, sz)
        h = self._hist
        i = self._hi * 4
        h[i] = sx
        h[i + 1] = sy
        h[i + 2] = sz
        h[i + 3] = self.seen
        self._hi = (self._hi + 1) % _HIST
        if self._hn < _HIST:
            self._hn += 1
        return True

    def _backoff(self):
        """Remove samples accepted in the second before a disturbance was detected."""
        h = self._hist
        c = self.c
        back = int(1000 / self.period_ms) + 1
        while self._hn:
            j = (self._hi - 1) % _HIST
            i = j * 4
            if self.seen - h[i + 3] > back:
                break
            x, y, z = h[i], h[i + 1], h[i + 2]
            self.fit.remove(x, y, z)
            self.cov.remove(x - c[0], y - c[1], z - c[2])
            self._hi = j
            self._hn -= 1
            self.removed += 1

    def add_temperature(self, celsius):
        self.temp_sum += celsius
        self.temp_n += 1

    def _solve(self):
        return self.fit.solve(field=None, prior=self.prior, scale=self.k)

    def tick(self, now_ms, diff):
        """Provisional solve every solve_every_s; returns True if one ran."""
        if self.fit.n < _MIN_PROVISIONAL:
            return False
        if diff(now_ms, self.last_solve) < self.cfg["solve_every_s"] * 1000:
            return False
        self.last_solve = now_ms
        try:
            cal = self._solve()
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
        return (self.coverage() >= self.cfg["min_coverage"] and pe is not None
                and pe <= self.cfg["target_error_nt"])

    def progress(self):
        pe = self.provisional_error
        return {
            "state": self.state,
            "n": self.fit.n,
            "seen": self.seen,
            "coverage": round(self.coverage(), 3),
            "pred_nt": None if pe is None else round(pe, 3),
            "rej_rate": self.rej_rate,
            "rej_dist": self.rej_dist,
            "rej_cap": self.rej_cap,
            "removed": self.removed,
            "ready": self.ready(),
        }

    def cancel(self):
        self.state = CANCELLED
        self.reason = "cancelled"
        self.message = "cancelled by the operator"

    def finish(self):
        """Solve and check. Returns (cal in code units, None, None) or (None, reason, message)."""
        try:
            cal = self._solve()
        except FitError as e:
            return self._fail(e.reason, str(e))
        problem = self.check(cal)
        if problem:
            return self._fail(problem[0], problem[1])
        self.state = DONE
        code_cal = cal.scaled_input(1.0 / self.window)
        code_cal.diagnostics["coverage"] = round(self.coverage(), 4)
        if self.temp_n:
            code_cal.meta["temperature_c"] = round(self.temp_sum / self.temp_n, 2)
        return code_cal, None, None

    def _fail(self, reason, message):
        self.state = FAILED
        self.reason = reason
        self.message = message
        return None, reason, message

    def check(self, cal):
        """Acceptance thresholds; (reason, message) for the first that fails, else None."""
        return check_calibration(cal, self.cfg, self.k)


def check_calibration(cal, cfg, k):
    """Physical and statistical sanity of a calibration on inputs of k nT/unit."""
    d = cal.diagnostics
    rms = d.get("rms")
    if rms is not None and rms > cfg["max_rms_nt"]:
        return ("rms_too_high", "fit residual %.2f nT > %.2f nT: hold the sensor away from iron and rotate smoothly"
                % (rms, cfg["max_rms_nt"]))
    obs = d.get("observability")
    if obs is not None and obs < cfg["min_observability"]:
        return ("poor_observability", "observability %.3f < %.3f: rotate about all three axes"
                % (obs, cfg["min_observability"]))
    pe = d.get("predicted_error")
    if pe is not None and pe > cfg["max_predicted_nt"]:
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
