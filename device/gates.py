"""Which decimated samples a calibration takes: rotation rate, coverage cap, disturbance.

    g = Gates(cfg, fit, cov, window, period_ms, centre)   # centre: sum units (prior offset or 0)
    g.sample(sx, sy, sz)      # True if it went into fit (and cov)
    g.use_provisional(cal, nt)   # a provisional fit good enough to judge disturbances, and the
                                 # disturbance gate from its residual, nT (session.py)

The gates, in order (each rejection is counted and reported). They work on the
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
   |B| (1 - (tau w)^2 / 2) while turning at w (docs/experiments/lag.md), so
   w <= sqrt(2 lag_tol_nt / B) / tau: 1610 deg/s for a 1 kHz Mag649 at
   lag_tol_nt 0.5 and B 50,000 nT (the 360 deg/s gate stands), 8 deg/s for a 5 Hz Mag648.
   Where that lag would lower the gate, the firmware de-lags the samples instead
   (`delag`, shared/delag.py) and the gate follows what de-lagging leaves
   (shared/delag.py configured_tau_s, gate_dps). The stride s spans enough samples that the allowed turn is a few 14-bit steps. The gate works
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

The accepted samples' last HIST stay in a ring (`hist`: x, y, z, sample index,
cell): the back-off removes from it, and the session reads it for the
residuals' sample-to-sample correlation (session.py); their batch sums over the
whole session (residuals.py) give the predicted error's widening.

Native: where deploy installed gatesc.mpy (device/native/gatesc.c; MicroPython boards of a
matching architecture) a Gates' `sample` is in C: the gates above with the exact |h_c|, and
for a sample taken fit.add, the cell's count, the batches' count (batches.added() for a batch's
last sample) and the hist ring, on the same
state (`_st`, `_ring`, `hist`); it hands the rest (the float |h_c|, the back-off, the tau sums,
sums past its words) to Gates.sample, the reference, before changing anything. A Python
sample frame here is a heap allocation (over 11 slots) plus ~2 k cycles a method call on an
RP2040: 62 -> 29 k cycles a sample, 109 -> 38 k with the disturbance gate
(tests/test_native_gatesc.py holds the two equal; `path` says which runs).
"""

import math
from array import array

from residuals import ResidualBatches
from shared.coverage import TAN_BITS
from shared.delag import configured_tau_s, lag_dps, sensor_tau_s
from shared.fixedpoint import FRACTION_BITS, NATIVE, ExactCorrection

try:
    from micropython import const
except ImportError:     # CPython: the value itself
    def const(x):
        return x
try:
    # Gates.sample in C where deploy installed the board's gatesc.mpy (MicroPython; ValueError:
    # a .mpy of another architecture or version); CPython and CircuitPython run the Python
    from gatesc import Sample as _NativeSample
except (ImportError, ValueError):
    _NativeSample = None

HIST = 256           # recent accepted samples kept for removal (5 ints each)
_RUN = 3             # consecutive outliers that make a disturbance
_GATE_BITS = 14      # gate/cell arithmetic: |v| < 2**14, so |v|^2 sums stay < 2**30
_G_SHIFT = 16        # rate gate: d^2 > (r^2 >> 16) * round(angle^2 * 2**16)
_MAX_STRIDE = 64     # rate gate baseline, samples (0.64 s at 100 samples/s)
# Gates._st, one array("i") that sample() and device/native/gatesc.c share (its enum): the
# counters and the chain's state, then the constants (an index costs what an attribute does on
# MicroPython; const: inlined there, no global each)
_SEEN = const(0)
_REJ_RATE = const(1)
_REJ_CAP = const(2)
_REJ_DIST = const(3)
_FRESH = const(4)
_FILLED = const(5)
_RI = const(6)
_RUN_N = const(7)
_HOLD = const(8)
_HIST_N = const(9)
_HIST_I = const(10)
_SH = const(11)
_CX = const(12)
_CY = const(13)
_CZ = const(14)
_STRIDE = const(15)
_G = const(16)
_CAP = const(17)
_EDGE = const(18)
_BACK = const(19)
_PROV = const(20)
_STATE = const(21)


def gate_dps(cfg, polled=False):
    """The rotation-rate gate: gate_rate_dps, or lower where the sensor's lag, or what
    de-lagging leaves of it, would shrink |B| by more than lag_tol_nt.

    De-lagged with a tau known to a fraction u (response_tol), the samples keep a lag of
    up to u tau, a first-order lag like the sensor's own: |B| short by B (u tau w)^2 / 2,
    so w <= sqrt(2 lag_tol / B) / (u tau) -- 164 deg/s for the Mag648 at u = 0.05, the
    whole gate_rate_dps at u <= 0.02. The de-lag's own residual, the central difference's
    tau (w T)^2 / 6 (shared/delag.py), is 7e-4 tau at 1 rev/s: far inside any u. Not
    bounded here: axes whose taus differ by a fraction s (which a common tau leaves) err
    first order in the rate, up to B w s tau / 2, and a response that is not first
    order leaves a term in w^2; the calibration's residuals show both (acceptance.py)."""
    tau = configured_tau_s(cfg, polled)
    if tau is not None:
        tau *= cfg["response_tol"]
    else:
        tau = sensor_tau_s(cfg)
    return min(cfg["gate_rate_dps"], lag_dps(cfg, tau))


def disturbance_limit(cfg, rms, predicted_error):
    """The disturbance gate (nT) against a provisional fit of this residual and predicted error."""
    return max(cfg["outlier_nt"], 4.0 * rms + 2.0 * predicted_error)


def zeros(n):
    """array("i") of n zeros in one block: array("i", bytes(4 n)) also needs a block as large for
    the bytes, two 5 KB runs for the ring where a Pico's fragmented 190 KB had one."""
    a = array("i", range(n))
    for i in range(n):
        a[i] = 0
    return a


def _zeroed(a):
    if len(a) != 5 * HIST:
        raise ValueError("hist must hold 5 * HIST ints")
    for i in range(len(a)):
        a[i] = 0
    return a


class Gates:
    def __init__(self, cfg, fit, cov, window, period_ms, centre, polled=False, native=True, hist=None):
        self.fit = fit
        self.cov = cov
        # shift that brings a full-scale sum (window * 2**23 codes) below 2**14
        sh = 0
        while (window << 23) >> sh >= (1 << _GATE_BITS):
            sh += 1
        self._st = st = zeros(_STATE)
        st[_SH] = sh
        st[_CX] = centre[0] >> sh
        st[_CY] = centre[1] >> sh
        st[_CZ] = centre[2] >> sh
        st[_FRESH] = 1              # no previous sample to compare with
        self.removed = 0
        self.provisional = None     # use_provisional: the fit the disturbance gate judges with
        self._exact = None          # ... as shared.fixedpoint's |h_c| in C, where the port has it
        self.dist_limit = cfg["outlier_nt"]
        st[_CAP] = cfg["cell_cap"]
        self._cuts = array("i", cov._cuts)      # the coverage cells, read inline in sample()
        st[_EDGE] = cov.edge
        self._counts = cov.counts
        # x, y, z, sample index, cell; hist: an array("i") of that length to use (calibration_flow.py's,
        # taken before the session's modules split the heap)
        self.hist = zeros(5 * HIST) if hist is None else _zeroed(hist)
        # the tau estimate (session.py attach): the Delag whose .ex .ey .ez are the current
        # sample's tau steps, the accumulators they go into, and the accepted ones' steps
        # beside hist (x, y, z each)
        self.lag = None
        self.tau_sums = None
        self.hist_e = None
        self.batches = ResidualBatches(fit, centre)   # the residuals' correlation over the session
        self.back = st[_BACK] = int(1000 / period_ms) + 1   # samples in one second (backoff)
        self.gate_dps = gate_dps(cfg, polled)
        g = self.gate_dps * math.pi / 180.0 * period_ms / 1000.0
        # compare with the sample `stride` back, so the allowed turn is >= 1/64 rad: a few
        # steps of the 14-bit vectors (a slow sensor's gate is ~1e-3 rad per sample)
        stride = 1
        while g * stride < 0.016 and stride < _MAX_STRIDE:
            stride += 1
        st[_STRIDE] = stride
        self._ring = array("i", bytes(4 * 3 * stride))   # the last `stride` shifted samples
        g = g * stride
        st[_G] = max(1, int(g * g * (1 << _G_SHIFT) + 0.5))   # max squared turn angle per stride
        # sample() in C where gatesc.mpy loads (native=False: the class's, the reference, as
        # the tests compare them): an instance attribute, found before the method, holding
        # these gates and Gates.sample for what it hands back
        self.path = "python"
        if native and _NativeSample is not None:
            self.sample = _NativeSample(self, Gates.sample)
            self.path = "native"

    # the counters, read by session.py, lagfit.py and residual_stats.py
    seen = property(lambda self: self._st[_SEEN])
    rej_rate = property(lambda self: self._st[_REJ_RATE])
    rej_cap = property(lambda self: self._st[_REJ_CAP])
    rej_dist = property(lambda self: self._st[_REJ_DIST])
    hist_n = property(lambda self: self._st[_HIST_N])
    hist_i = property(lambda self: self._st[_HIST_I])

    def use_provisional(self, cal, dist_limit):
        """Judge disturbances against `cal` (sum units; None: not yet) at `dist_limit` nT. Where
        fitsums.mpy has the exact |h_c| (shared/fixedpoint.py, path "native") the gate compares
        integers in 1/2**FRACTION_BITS milli-nT: ~20 k cycles a sample on an RP2040 against
        ~95 k for the float |h_c|, whose every operation allocates (docs/benchmarks.md)."""
        self.provisional = cal
        self._st[_PROV] = cal is not None
        self.dist_limit = dist_limit
        self._exact = None
        if cal is not None and NATIVE:
            ex = ExactCorrection(cal, 1)
            if ex.path == "native":
                self._exact = ex
                unit = 1000 << FRACTION_BITS
                field = int(cal.field * unit + 0.5)
                limit = int(dist_limit * unit)
                settled = int(0.1 * dist_limit * unit)
                # |m - field| > limit as two comparisons with the bounds: m is a big int on a
                # 32-bit port (|h_c| ~ 2**34 units), and each subtraction or abs() of it is
                # a heap allocation per sample
                self._hi_q = field + limit
                self._lo_q = field - limit
                self._hi_settled_q = field + settled
                self._lo_settled_q = field - settled
                # and for gatesc.mpy, which judges in C (_PROV 2): the correction's limbs and the
                # bounds' (each a 64-bit two's complement in 16-bit limbs, hc.h's number())
                bounds = (self._hi_q, self._lo_q, self._hi_settled_q, self._lo_settled_q)
                if max(bounds) < 1 << 62 and min(bounds) > -1 << 62:
                    self._bounds = array("H", [(v >> k) & 0xFFFF for v in bounds for k in (0, 16, 32, 48)])
                    self._st[_PROV] = 2

    def break_chain(self):
        """Samples were lost: the next one has no neighbour to gate its turn rate against."""
        self._st[_FRESH] = 1

    def sample(self, sx, sy, sz):
        """Gate one decimated sample; return True if it went into the fit. (Where gatesc.mpy
        loads, the instance's `sample` is its C version of this: device/native/gatesc.c.)"""
        st = self._st
        st[_SEEN] += 1
        sh = st[_SH]
        x = (sx >> sh) - st[_CX]
        y = (sy >> sh) - st[_CY]
        z = (sz >> sh) - st[_CZ]
        if st[_FRESH]:
            st[_FRESH] = 0
            st[_FILLED] = 0
        r = self._ring
        i = st[_RI] * 3
        dx = x - r[i]
        dy = y - r[i + 1]
        dz = z - r[i + 2]
        r[i] = x
        r[i + 1] = y
        r[i + 2] = z
        st[_RI] = (st[_RI] + 1) % st[_STRIDE]
        if st[_FILLED] < st[_STRIDE]:
            st[_FILLED] += 1
            return False
        # 1. rotation rate: chord^2 > angle^2 |r|^2, in small ints
        if dx * dx + dy * dy + dz * dz > ((x * x + y * y + z * z) >> _G_SHIFT) * st[_G]:
            st[_REJ_RATE] += 1
            return False
        if not (x or y or z):
            st[_REJ_RATE] += 1   # no direction (a dead front end): nothing to place
            return False
        # 2. coverage cell cap: shared.coverage.Coverage.cell inlined (a method call each is
        # ~2 k cycles on an RP2040; tests/test_device_gates_cells.py holds them equal on every boundary)
        cov = self.cov
        ax = x if x >= 0 else -x
        ay = y if y >= 0 else -y
        az = z if z >= 0 else -z
        if ax >= ay and ax >= az:
            face = 0 if x >= 0 else 1
            major = ax
            p = y
            q = z
        elif ay >= az:
            face = 2 if y >= 0 else 3
            major = ay
            p = x
            q = z
        else:
            face = 4 if z >= 0 else 5
            major = az
            p = x
            q = y
        p <<= TAN_BITS
        q <<= TAN_BITS
        i = j = 0
        for cut in self._cuts:
            c = cut * major
            if p >= c:
                i += 1
            if q >= c:
                j += 1
        e = st[_EDGE]
        cell = (face * e + i) * e + j
        n = self._counts[cell]
        if n >= st[_CAP]:
            st[_REJ_CAP] += 1
            return False
        # 3. disturbance, against the provisional fit, only where it interpolates:
        # in a cell that already holds samples, and once its predicted error is
        # well below the gate. A new orientation is never called a disturbance.
        pc = self.provisional
        if pc is not None and (n >= 3 or st[_HOLD]):
            ex = self._exact
            if ex is not None:
                m = ex.magnitude(sx, sy, sz)
                out = m > self._hi_q or m < self._lo_q
            else:
                m = abs(pc.magnitude(sx, sy, sz) - pc.field)   # the deviation, nT
                out = m > self.dist_limit
            if out:
                st[_REJ_DIST] += 1
                st[_RUN_N] += 1
                if st[_RUN_N] == _RUN:
                    self._backoff()   # a disturbance, not a lone outlier: its onset went in
                    st[_HOLD] = self.back
                return False
            st[_RUN_N] = 0
            if st[_HOLD]:
                # back-off: a dipole's 1/r^3 tail stays above the noise long after it
                # falls under the gate; hold until it is under a tenth of the gate for 1 s
                st[_REJ_DIST] += 1
                if (m > self._hi_settled_q or m < self._lo_settled_q) if ex is not None else \
                        m > 0.1 * self.dist_limit:
                    st[_HOLD] = self.back
                else:
                    st[_HOLD] -= 1
                return False
        self.fit.add(sx, sy, sz)
        cov.add_to(cell)
        ts = self.tau_sums
        if ts is not None:
            lg = self.lag
            ts.add(sx, sy, sz, lg.ex, lg.ey, lg.ez)
            he = self.hist_e
            i = st[_HIST_I] * 3
            he[i] = lg.ex
            he[i + 1] = lg.ey
            he[i + 2] = lg.ez
        self.batches.added()        # after the tau nodes took it: a batch may close on it
        h = self.hist
        i = st[_HIST_I] * 5
        h[i] = sx
        h[i + 1] = sy
        h[i + 2] = sz
        h[i + 3] = st[_SEEN]
        h[i + 4] = cell
        st[_HIST_I] = (st[_HIST_I] + 1) % HIST
        if st[_HIST_N] < HIST:
            st[_HIST_N] += 1
        return True

    def last_direction(self):
        """[x, y, z] of the latest sample about the centre (14-bit sums, as the cells see it):
        where the sensor points now, for the progress event; None before the first sample."""
        st = self._st
        if not st[_SEEN]:
            return None
        i = ((st[_RI] - 1) % st[_STRIDE]) * 3
        r = self._ring
        return [r[i], r[i + 1], r[i + 2]]

    def _backoff(self):
        """Remove samples accepted in the second before a disturbance was detected."""
        h = self.hist
        back = self.back
        st = self._st
        while st[_HIST_N]:
            j = (st[_HIST_I] - 1) % HIST
            i = j * 5
            if st[_SEEN] - h[i + 3] > back:
                break
            self.fit.remove(h[i], h[i + 1], h[i + 2])
            if self.tau_sums is not None:
                he = self.hist_e
                self.tau_sums.remove(h[i], h[i + 1], h[i + 2], he[j * 3], he[j * 3 + 1], he[j * 3 + 2])
                self.batches.removed(h[i], h[i + 1], h[i + 2], he[j * 3], he[j * 3 + 1], he[j * 3 + 2])
            else:
                self.batches.removed(h[i], h[i + 1], h[i + 2])
            self.cov.remove_from(h[i + 4])
            st[_HIST_I] = j
            st[_HIST_N] -= 1
            self.removed += 1
