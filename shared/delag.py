"""Undo the sensor's and the ADC's lag on the decimated integer samples: exact, the same on every interpreter.

    from shared.delag import Delag, tau_us
    dl = Delag(window=2)
    dl.set_taus([31831] * 3, rate=1000, decim=10)   # per-axis tau in whole us; None: off
    if dl.push(sx, sy, sz, st):                     # two samples late: that one is ready
        use(dl.x, dl.y, dl.z, dl.t)                 # boxcar sums with the lag undone
    dl.reset()                                      # after a gap: neighbours are not neighbours
    dl.join(True)                                   # one sample lost after the next push: bridged

Why: a first-order sensor of time constant tau = 1 / (2 pi f_c) reading the field r obeys
tau y' + y = r, so r = y + tau y' exactly. The ADS1292's sinc3 filter and the firmware's
boxcar are linear and time invariant too, and not mere delays: any filter whose impulse
response has the variance s^2 shrinks a field turning at w by B (w s)^2 / 2 (its transfer
function is e^(-i w mean) (1 - w^2 s^2 / 2 + ...)), as a first-order lag of tau = s does, and
de-lagging with tau lengthens it by B (w tau)^2 / 2. With `delag_adc` the firmware de-lags
with the whole response's tau = sqrt(tau_s^2 + s_sinc^2 + s_box^2) (response_tau_s): 0.725 ms
for a 1 kHz sensor at the defaults, whose 0.16 ms alone misses 0.27 nT of |B| at 1 rev/s, an
error that follows the hand's pace (the Mag649's full-sphere error 0.044 nT at 1 rev/s,
0.012 nT de-lagged so, python -m desktop.bench.delag); `fluxcal fit --lag auto` finds
0.524 ms on the conversions themselves (the sinc3 and the sensor: sqrt(0.5^2 + 0.16^2)).
`delag_adc` is "auto" by default: on, where the board's DRDY is an interrupt and where it is
polled (CircuitPython), whose one-sample gaps are bridged (join, below); off, only a slow
sensor is de-lagged, by its own tau.

Where the derivative is taken: at the decimated rate f_s = rate / decim, by the five-point
central difference (Richardson's combination of the spans T and 2 T, T = 1 / f_s),

    x_n = y_n + k (8 (y_(n+1) - y_(n-1)) - (y_(n+2) - y_(n-2))),   k = tau f_s / 12,

output two samples (20 ms at the defaults) late.
- Central, not backward: y_n - y_(n-1) is the derivative at t_n - T/2, a radial error
  tau (T/2) y'' that shrinks |B| by B tau T w^2 / 2 -- 75 nT for the Mag648 (tau 31.8 ms)
  at 0.5 rev/s.
- Five points, not three: the three-point (y_(n+1) - y_(n-1)) / 2T reads y' with an error
  T^2 y'''/ 6, and the third derivative of a hand's turn has a radial part -3 B w a (w the
  rate, a the angular acceleration): |B| off by tau T^2 B w a / 2, which follows the hand's
  reversals and tremor. Decimated Mag648 captures (fluxcal simulate, hand, seed 5) fitted
  with their ellipsoid leave 1.47 nT rms at 0.5 rev/s and 5.9 nT at 1 rev/s that way, 0.58
  and 0.78 nT with five points (error T^4 y^(5) / 30), for 1.3 times the three-point's
  noise.
- Decimated, not at every conversion: the de-lag term's white noise is
  (tau f_s / 12) sqrt 130 times a sample's, 3.0 for the Mag648 at 100 samples/s (the
  survey's 0.1 s block average cancels most of it: the differences telescope); between
  1 ms conversions it would be ten times that, and the interrupt handler would pay for it.

Integers: k is num / 2**shift, num = round(tau f_s 2**shift / 12) computed from tau in whole
microseconds and the integer rate and decimation (the only float step is a tau in seconds
to whole microseconds, the same on a 30-bit float unless tau lies within 1e-9 s of a half
microsecond). With d1 = y_(n+1) - y_(n-1) = h1 2**shift + l1, and d2 = y_(n+2) - y_(n-2)
likewise (0 <= l < 2**shift),

    round(num (8 d1 - d2) / 2**shift) = 8 num h1 - num h2 + ((8 num l1 - num l2 + 2**(shift-1)) >> shift)

exactly (ties up): shift is chosen so that 8 num < 2**(30 - shift), and |8 num h1|,
|num h2| <= 2**27 is checked before multiplying, so every value stays a small int
(|.| < 2**30: no heap allocation on MicroPython). A de-lag term that large (2**26 nT at
the handheld's scale), or a result beyond the boxcar's full scale (window 2**23), is no
field: the sample is dropped and counted in `saturated`.

A gap of one sample (a board that polls DRDY loses one block every few: CircuitPython) need
not cost four: `join` (called by the screen's Screen.bridge once it judged the sample before
the hole across it) fills the hole, once the sample after it arrives, with the cubic through
the three samples before it and that one, y_0 = (y_-3 - 4 y_-2 + 6 y_-1 + y_1 + 2) >> 2
(Lagrange at -3, -2, -1, 1; error T^4 y''''/4, noise 1.8 times a sample's), and the de-lag
runs on as if nothing were lost; the fill itself never comes out. Its error reaches a
neighbour through at most 8 k times it: at 1 rev/s B (w T)^4 / 4 = 0.19 nT, times 0.05 for
the whole response of a 1 kHz sensor (0.01 nT), 2.1 for the Mag648 (0.4 nT, along the
field). While a hole is bridged push is _bridged (Python: the samples queue one behind while
the fill comes out, then push is the native one again); on_hole (the gates' break_chain) is
called before the first sample after the hole comes out: its turn rate has no neighbour.

Native: where deploy installed delagc.mpy (device/native/delagc.c; MicroPython boards of a
matching architecture), push runs in C once five samples are held: the same rotation of the
same lists, the same terms in 64-bit words, no allocation; any push whose numbers do not fit
its words goes to Delag.push, the reference, before anything changes. Elsewhere (CPython,
CircuitPython) Delag.push runs every sample; `.path` says which ("native" or "python": status).
"""

import math

try:
    # push in C where deploy installed the board's delagc.mpy (MicroPython; ValueError: a .mpy
    # of another arch or version)
    from delagc import Push as _NativePush
except (ImportError, ValueError):
    _NativePush = None

_LIMIT = 1 << 27      # the largest part of a de-lag term, sum units
_QUEUE = 4            # samples a bridge may hold back (two holes a sample apart need 2)
_MAX_SHIFT = 16
DELAY = 2             # samples between a push and the de-lagged sample it completes


def lag_dps(cfg, tau):
    """The turn rate (deg/s) at which a first-order lag tau (s) shrinks |B| by the firmware
    config's lag_tol_nt: B (tau w)^2 / 2 (B its field_nt, else 50,000 nT)."""
    field = cfg["field_nt"] or 50000.0
    return math.sqrt(2.0 * cfg["lag_tol_nt"] / field) / tau * 180.0 / math.pi if tau > 0.0 else 1e9


def sensor_tau_s(cfg):
    """The sensor's own first-order time constant (s): 1 / (2 pi sensor_bandwidth_hz)."""
    return 1.0 / (2.0 * math.pi * cfg["sensor_bandwidth_hz"])


def response_tau_s(cfg):
    """The time constant (s) that undoes the whole response to second order in the turn rate:
    the sensor's, the ADS1292's sinc3 (three boxcars of one conversion, 1 / rate: variance
    1 / (4 rate^2); datasheet section 8.3.1.4, the digital decimation filter) and the firmware's
    boxcar of `window` conversions 1 / rate apart (variance (window^2 - 1) / (12 rate^2)).
    Variances add under convolution, and a first-order lag's is tau_s^2."""
    r = float(cfg["rate"])
    w = cfg["window"]
    return math.sqrt(sensor_tau_s(cfg) ** 2 + 0.25 / (r * r) + (w * w - 1) / (12.0 * r * r))


def configured_tau_s(cfg, polled=False):
    """The tau (s) the firmware config de-lags the samples with, or None: with `delag_adc` the
    whole response's (response_tau_s) whenever `delag` is on; else the sensor's own where its
    lag would bring the rate gate under gate_rate_dps (device/gates.py): a sensor fast enough
    for the gate is left as it is. polled: the board polls DRDY (device/hal.py polls_drdy;
    adc_delagged)."""
    if not cfg["delag"]:
        return None
    if adc_delagged(cfg, polled):
        return response_tau_s(cfg)
    return sensor_tau_s(cfg) if sensor_is_slow(cfg) else None


def adc_delagged(cfg, polled=False):
    """`delag_adc` for this board: "auto" is on, where DRDY is an interrupt and where it is
    polled (polled True): there a gap comes every few samples, and each would cost the de-lag
    four (Delag.reset), but the usual one, one sample, is bridged (Delag.join; 2,184 samples
    taken in 120 s at 1 rev/s on the simulated polled board, 22 without the bridge). polled
    no longer changes it; the callers (device/gates.py, session.py, survey.py) still pass it."""
    on = cfg["delag_adc"]
    return True if on == "auto" else on


def sensor_is_slow(cfg):
    """True when the sensor's own lag would bring the rate gate under gate_rate_dps
    (device/gates.py): then its tau is worth estimating (device/lagfit.py); a fast sensor's
    response is the ADC's, known from the datasheet."""
    return lag_dps(cfg, sensor_tau_s(cfg)) < cfg["gate_rate_dps"]


def tau_us(tau_s):
    """A time constant in seconds as whole microseconds (the de-lag's unit)."""
    return int(tau_s * 1e6 + 0.5)


def coefficients(taus_us, rate, decim):
    """(shift, [num] * 3): k_i = tau_i rate / (12 decim) as num_i / 2**shift, exactly rounded;
    shift the largest (<= 16) with every 8 num_i < 2**(30 - shift)."""
    den = 12000000 * decim
    shift = _MAX_SHIFT
    while True:
        nums = [(t * rate * (1 << shift) + den // 2) // den for t in taus_us]
        if 8 * max(nums) < 1 << (30 - shift) or shift == 1:
            return shift, nums
        shift -= 1


class Delag:
    def __init__(self, window, native=True):
        self.top = window << 23      # |a de-lagged sum| stays under the boxcar's full scale
        self.saturated = 0           # samples dropped: a de-lag term no field makes
        self.taus_us = None          # None: off (push is not called)
        self.x = self.y = self.z = self.t = 0
        self.ex = self.ey = self.ez = 0   # the de-lag terms of the tau steps (set_taus steps_us)
        self._dk = None
        # the last five samples, oldest first: (x, y, z, temperature) each
        self._h = [[0, 0, 0, 0] for _ in range(5)]
        # a bridge's state (join): the samples not yet pushed, oldest first, [x, y, z, t, fill]
        # each; which of the five held are fills; holes before the next pushes (bit i: before
        # the i-th from now); a fill came out since the last sample
        self._q = [[0, 0, 0, 0, 0] for _ in range(_QUEUE)]
        self._nq = 0
        self._v = [0, 0, 0, 0, 0]
        self._holes = 0
        self._after = False
        self.on_hole = None
        self._fast = self.push       # push when no hole is bridged: the class's, bound once
        self._bridge = self._bridged  # bound once too: join allocates nothing
        self.reset()
        # push in C where delagc.mpy loads (native=False: the class's push, the reference, as
        # the tests compare them), set by set_taus: an instance attribute, found before the method
        self.path = "native" if native and _NativePush is not None else "python"

    def set_taus(self, taus_us, rate, decim, steps_us=None):
        """De-lag with these per-axis time constants (whole us) at rate / decim samples/s;
        None switches it off. The held samples are raw, so they stay valid. steps_us: per-axis
        tau steps (whole us, each below its tau) whose de-lag terms push also leaves in .ex .ey
        .ez (shared/tausums.py: the samples at any tau); None: not formed."""
        if taus_us is not None and (len(taus_us) != 3 or min(taus_us) < 0):
            raise ValueError("taus_us must be 3 non-negative integers")
        if taus_us is None or not max(taus_us):
            self.taus_us = None
            return
        if self.taus_us is None:
            self.reset()   # pushes stopped while off: what is held is stale
        self.taus_us = list(taus_us)
        if steps_us is not None and (len(steps_us) != 3 or min(steps_us) < 0 or
                                     max(s - t for s, t in zip(steps_us, taus_us)) > 0):
            raise ValueError("steps_us must be 3 non-negative integers no larger than the taus")
        # the steps' coefficients share the taus' shift (no larger than theirs: the same shift)
        self._shift, k = coefficients(self.taus_us + list(steps_us or ()), rate, decim)
        self._k = k[:3]
        self._dk = k[3:] if steps_us is not None else None
        self._lim = [(_LIMIT // (8 * n) if n else _LIMIT) for n in k]
        if self.path == "native":
            # it takes the lists and numbers just set (and the history, never replaced)
            self._fast = _NativePush(self, Delag.push)
        if self._nq or self._holes or max(self._v):
            self.reset()   # a bridge in progress: start again
        self.push = self._fast

    def reset(self):
        """Forget the held samples (a gap: the next one has no neighbour)."""
        self._n = 0
        self._nq = 0
        self._holes = 0
        self._after = False
        v = self._v
        for i in range(5):
            v[i] = 0
        self.push = self._fast

    def can_join(self):
        """True when a hole after the next push could be bridged (join): two samples held (a
        third coming) and room to queue."""
        return self.taus_us is not None and self._n + self._nq >= 2 and self._nq <= _QUEUE - 2

    def join(self, ok):
        """One sample is lost after the next one pushed: bridge it (ok), or start again (ok
        False: the screen let go of that one; on_hole is called)."""
        if not ok or not self.can_join():
            self.reset()
            if self.on_hole is not None:
                self.on_hole()
            return
        self._holes |= 2
        self.push = self._bridge

    def _bridged(self, x, y, z, t):
        """push while a hole is bridged: the sample after a hole queues the hole's fill first."""
        m = self._holes
        self._holes = m >> 1
        if m & 1 and not self._fill(x, y, z):
            self.join(False)               # too little held: start again from this one
            return self.push(x, y, z, t)
        self._queue(x, y, z, t, 0)
        q = self._q
        v = self._v
        fast = self._fast
        ok = False
        while self._nq:
            s = q[0]
            for i in range(self._nq - 1):
                q[i] = q[i + 1]
            self._nq -= 1
            q[self._nq] = s
            full = self._n >= 4            # a sample comes out of this push (or is dropped)
            ok = fast(s[0], s[1], s[2], s[3])
            v[0] = v[1]
            v[1] = v[2]
            v[2] = v[3]
            v[3] = v[4]
            v[4] = s[4]
            if full and v[2]:
                self._after = True         # the fill itself: no sample, push on
                ok = False
                continue
            if ok:
                if self._after:
                    self._after = False
                    if self.on_hole is not None:
                        self.on_hole()
                break
        if not (self._nq or self._holes or v[3] or v[4]):
            self.push = fast               # caught up: every fill out
        return ok

    def _queue(self, x, y, z, t, fill):
        s = self._q[self._nq]
        s[0] = x
        s[1] = y
        s[2] = z
        s[3] = t
        s[4] = fill
        self._nq += 1

    def _recent(self, i):
        """The i-th latest sample (0: the last), queued or held."""
        nq = self._nq
        return self._q[nq - 1 - i] if i < nq else self._h[4 - (i - nq)]

    def _fill(self, x, y, z):
        """Queue the hole's fill from the three samples before it and (x, y, z) after it;
        False when fewer than three are held or the queue is full."""
        if self._n + self._nq < 3 or self._nq > _QUEUE - 2:
            return False
        a = self._recent(2)
        b = self._recent(1)
        c = self._recent(0)
        # (a - 4 b + 6 c + x + 2) >> 2 as c plus neighbours' differences: small ints for a field
        self._queue(_cubic(a[0], b[0], c[0], x), _cubic(a[1], b[1], c[1], y), _cubic(a[2], b[2], c[2], z), c[3], 1)
        return True


    def push(self, x, y, z, t):
        """Take sample n + 2; True when sample n, de-lagged, is in .x .y .z (.t its temperature)."""
        h = self._h
        s = h[0]            # the oldest slot is reused for the newest sample: no allocation
        h[0] = h[1]
        h[1] = h[2]
        h[2] = h[3]
        h[3] = h[4]
        h[4] = s
        s[0] = x
        s[1] = y
        s[2] = z
        s[3] = t
        if self._n < 4:
            self._n += 1
            return False
        a = h[0]
        b = h[1]
        c = h[2]
        d = h[3]
        k = self._k
        lim = self._lim
        sh = self._shift
        top = self.top
        vx = _delagged(c[0], d[0] - b[0], x - a[0], k[0], lim[0], sh, top)
        vy = _delagged(c[1], d[1] - b[1], y - a[1], k[1], lim[1], sh, top)
        vz = _delagged(c[2], d[2] - b[2], z - a[2], k[2], lim[2], sh, top)
        if vx is None or vy is None or vz is None:
            self.saturated += 1
            return False
        dk = self._dk
        if dk is not None:
            # no larger than the de-lag terms just taken: within the same limits
            self.ex = _delagged(0, d[0] - b[0], x - a[0], dk[0], lim[3], sh, top)
            self.ey = _delagged(0, d[1] - b[1], y - a[1], dk[1], lim[4], sh, top)
            self.ez = _delagged(0, d[2] - b[2], z - a[2], dk[2], lim[5], sh, top)
        self.x = vx
        self.y = vy
        self.z = vz
        self.t = c[3]
        return True


def _delagged(c, d1, d2, num, lim, shift, top):
    """c + round(num (8 d1 - d2) / 2**shift) (ties up) in small ints, or None for a term
    beyond the limits (module docstring)."""
    h1 = d1 >> shift
    h2 = d2 >> shift
    if h1 > lim or h1 < -lim or h2 > 8 * lim or h2 < -8 * lim:
        return None
    n8 = num << 3
    v = c + n8 * h1 - num * h2 + ((n8 * (d1 - (h1 << shift)) - num * (d2 - (h2 << shift)) + (1 << (shift - 1))) >> shift)
    if v >= top or v <= -top:
        return None
    return v


def _cubic(a, b, c, d):
    """The cubic through a, b, c (at -3, -2, -1) and d (at 1) at 0, rounded (ties up)."""
    return c + ((a - b - 3 * (b - c) + d - c + 2) >> 2)
