"""Decimated samples the fit and the survey must not see: one-sample spikes and clipped ones.

    sc = Screen(scale, window, spike_nt)
    if sc.push(sx, sy, sz, st):      # one sample late: judges the one before
        use(sc.x, sc.y, sc.z, sc.t)
    sc.reset()                       # after a gap in the stream: neighbours are not neighbours
    sc.bridge(on_joined)             # or, one sample lost: judge the one held across it

A flipped data bit (a noisy SPI line: [DS] checks nothing but the status nibble)
moves one frame's code by 2**k; in a boxcar sum it shows as one sample off the
line through its neighbours, and back. The field cannot do that: a rotating
vector bends by |v|**2 / |h| per sample (centripetal), a turning hand adds
B alpha dt**2 at a reversal, and a real step (walking over iron) stays.
So sample i is a spike when it departs from BOTH neighbours in the SAME
direction by more than that bend plus a threshold:
    min(|x_i - x_(i-1)|, |x_i - x_(i+1)|) > spike_nt + max(TYPICAL * typical, 2 |v|**2 / |h|)
on one axis (nT), with TYPICAL = 4 and `typical` a running mean of that same quantity
(weight 1/16, learnt one sample late; it is large while the hand reverses quickly,
noise-sized at rest). A step fails the test (x_i equals its next neighbour); smooth
motion fails it (the two differences have opposite signs). A false alarm costs one
sample; a spike let through costs nT in the survey (docs/reliability.md has both rates).

In integers: the MicroPython ports box every float (a heap allocation per operation,
slower as the heap fills), a small int (|n| < 2**30) is none. The screen's nT are
integers of 2**-12 nT (UNIT_BITS); an axis's k = scale / window nT per sum unit enters
as m / 2**sh with m of 13 significant bits (2**12 <= m < 2**13, rounded once, exactly,
from the interpreter's float: SCALE_BITS), so a difference s of sums is (s * m) >> sh
units, a small int for |s| < 2**17 (a turning hand's bends at window 2 are ~2**15; a
larger one, a spike or a step, is a big integer, exact and slower). The running mean of
2 x the bend (= TYPICAL * typical) is rounded to the unit each sample.
Resolution: every quantity is within 2**-11 of itself (0.05 %) plus 2**-8 nT of the
float screen's, so a verdict differs from the float one's only for a sample that
close to its threshold (tests/test_device_screen.py counts them on the simulator's
streams). A sample stands out by at most half its bend |2c - p - n| (the nearer
neighbour), which the running mean needs anyway: only where half the largest bend is
past spike_nt + TYPICAL * typical (a spike, a sharp turn) is the stand-out computed,
and only where that is past too the bend |v|^2 / |h|, compared exactly (squared, no
root) in big integers. Integers are exact: the verdicts are the same on every
interpreter, CPython, MicroPython and the 30-bit floats of CircuitPython alike (for the
same scale and spike_nt as each parses them; a scale within 2**-22 of a rounding edge
of its 13 bits could round apart on a 30-bit float).

Clipped: a boxcar of full-scale codes ([DS 8.3.8] saturates at 0x7FFFFF / 0x800000)
means the sensor or the PGA gain exceeds the ADC's range; the sample is not
the field (session.py names it `clipped` when it happens during a calibration).

One sample lost (a board that polls DRDY loses one block every few: CircuitPython), the
screen need not let go of the two it holds: `bridge` doubles c - p, so that the next push
judges c against p and n two periods on by the bend of the three, 2 (c - p) - (n - c) (3 a T^2
where an even spacing's is a T^2: learnt as a third of it), with 3 times the allowance (a
turn's apex stands out by a T^2 so, twice an even spacing's), and halves n - c after it (the
next judgement's c - p, per period: its bend reads 1.5 times, and a spike on that sample stands
out by half). Then on_joined(True) says that c came out before the hole (the de-lag bridges it:
shared/delag.py Delag.join); False where c did not (a spike or clipped: the screen starts again).

Native: where deploy installed screenc.mpy (device/native/screenc.c; MicroPython boards of
a matching architecture), a Screen's push is in C for the common case (a sample that is not
clipped, with two held neighbours, judged good without the stand-out: no allocation); it
hands any other push, and any whose numbers do not fit its words, to Screen.push, the
reference, before changing anything. Elsewhere (CircuitPython, the desktop) Screen.push runs
every sample. The state is the same attributes either way, so verdicts, counters and outputs
are the same integers (tests/test_native_screen.py); `.path` says which runs ("native" or
"python": status).
"""

from shared.fixedpoint import float_pair

try:
    # the common path of push in C (device/native/screenc.c), where deploy installed the board's
    # build (MicroPython; ValueError: a .mpy of another arch or version)
    from screenc import Push as _NativePush
except (ImportError, ValueError):
    _NativePush = None

CLIP_CODES = 8323072   # 2**23 - 2**16: within 0.8 % of full scale
TYPICAL = 4            # times the running mean bend a sample may stand out by
UNIT_BITS = 12         # the screen's nT unit: 2**-12 nT
SCALE_BITS = 12        # an axis's multiplier: 2**12 <= m < 2**13 (rounding: 2**-13 relative)


def _nearest(p, shift, den):
    """p = (m, e), a float's exact pair: m 2**(e + shift) / den rounded to the nearest integer."""
    k = p[1] + shift
    num = p[0] << k if k >= 0 else p[0]
    den = den if k >= 0 else den << -k
    return (2 * num + den) // (2 * den)


def multiplier(scale, window):
    """(m, sh): scale / window nT per sum unit = m / 2**sh units of 2**-UNIT_BITS nT, m rounded
    to SCALE_BITS + 1 bits (sh >= 0: a coarser k keeps sh = 0 and m's extra bits)."""
    p = float_pair(scale)
    sh = 0
    m = _nearest(p, UNIT_BITS, window)
    while m < 1 << SCALE_BITS:
        sh += 1
        m = _nearest(p, UNIT_BITS + sh, window)
    return m, sh


def _out(a, e, m, sh):
    """How far c stands out from p and n on one axis (a = c - p, e = c - n, sums), in units:
    the nearer of the two where both are on the same side, else 0."""
    if a > 0 and e > 0:
        return ((a if a < e else e) * m) >> sh
    if a < 0 and e < 0:
        return (-(a if a > e else e) * m) >> sh
    return 0


class Screen:
    def __init__(self, scale, window, spike_nt, native=True):
        # per axis: nT per sum unit as (m, sh), the screen's units (s * m) >> sh
        mx, sx = multiplier(scale[0], window)
        my, sy = multiplier(scale[1], window)
        mz, sz = multiplier(scale[2], window)
        self.clip = c = CLIP_CODES * window
        self.spike_nt = spike_nt
        self._spike = sp = _nearest(float_pair(spike_nt), UNIT_BITS, 1)   # in units
        self._k = (c, -c, sp, mx, sx, my, sy, mz, sz)   # one unpacking a push
        self._g = max(sx, sy, sz)     # the bend's common fraction bits
        self.spikes = 0      # samples rejected as spikes
        self.clipped = 0     # samples rejected as clipped
        self.clip_axis = None   # the axis of the last one (0, 1, 2)
        self.x = self.y = self.z = self.t = None   # the last good sample (there before a push
        # makes one: a store then allocates nothing)
        # The state, one list (an index costs about what an attribute does on MicroPython, one
        # unpacking reads it all, and the native push finds it with one look-up):
        #   0-6  the held samples as c - p and c: ax, ay, az, cx, cy, cz, ct
        #   7    n: samples held, 0, 1 (c) or 2 (p, c)
        #   8    thr: spike_nt + allow, units; allow = TYPICAL * typical, the running mean of 2 x the bend
        #   9    pending: the last accepted sample's 2 x bend, not yet learnt (< 0: none)
        self._st = [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
        self.reset()
        # push in C where screenc.mpy loads (native=False: the class's push, the reference, as
        # the tests compare them): an instance attribute, found before the method, holding
        # this screen and Screen.push for what it hands back
        self.path = "python"
        if native and _NativePush is not None:
            self.push = _NativePush(self, Screen.push)
            self.path = "native"

    def reset(self):
        """Forget the held samples (a gap: the next one has no neighbour)."""
        st = self._st
        st[7] = 0
        st[8] = self._spike
        st[9] = -1

    def held(self):
        """Samples held: 0, 1 or 2 (p and c: the next push judges c)."""
        return self._st[7]

    def bridge(self, on_joined):
        """One sample was lost after the last pushed: judge the one held (c) across the hole at the
        next push, then on_joined(c came out). False (nothing changed) unless two are held."""
        st = self._st
        if st[7] != 2:
            return False
        st[0] <<= 1       # c - p as the two periods from c to n
        st[1] <<= 1
        st[2] <<= 1
        self._joined = on_joined
        self._fast = self.push
        self.push = self._across
        return True

    def _across(self, x, y, z, t):
        """push, once, after a lost sample (bridge)."""
        self.push = self._fast
        st = self._st
        thr = st[8]
        pend = st[9]
        sp = self._spike
        # c at a turn's apex stands out from n two periods on by 4 a T^2 / 2, from p doubled by
        # a T^2 (twice the a T^2 / 2 of an even spacing): judged with 3 times the allowance
        st[8] = sp + 3 * (thr - sp)
        ok = self._fast(x, y, z, t)
        # the allowance learns as push does (Screen.push: the step (p - allow) / 16), from thr
        st[8] = thr + ((pend + sp - thr + 8) >> 4) if ok and pend >= 0 else thr
        if ok:
            st[0] >>= 1   # n - c over two periods: per period, as the next judgement's c - p
            st[1] >>= 1
            st[2] >>= 1
            if st[9] >= 0:
                st[9] //= 3   # 2 (c - p) - (n - c) is 3 a T^2 where 2c - p - n is a T^2
        else:
            self.reset()
        self._joined(ok)
        return ok

    def allowance(self):
        """TYPICAL * typical, in units of 2**-UNIT_BITS nT (an int)."""
        return self._st[8] - self._spike

    def push(self, x, y, z, t):
        """Take the next sample; True when the one before it is good (it is then in .x .y .z .t)."""
        c, nc, sp, mx, sx, my, sy, mz, sz = self._k
        if x >= c or x <= nc or y >= c or y <= nc or z >= c or z <= nc:
            self.clipped += 1
            self.clip_axis = 0 if (x >= c or x <= nc) else (1 if (y >= c or y <= nc) else 2)
            self.reset()     # a clipped sample is no neighbour either
            return False
        st = self._st
        if st[7] < 2:
            st[0] = x - st[3]   # c - p once the next is c
            st[1] = y - st[4]
            st[2] = z - st[5]
            st[3] = x
            st[4] = y
            st[5] = z
            st[6] = t
            st[7] += 1
            return False
        ax, ay, az, cx, cy, cz, ct, _, thr, pend = st
        # the bend of c, |2c - p - n| = |(c - p) - (n - c)| per axis in units, the largest
        ex = x - cx
        e = ax - ex
        e = ((e if e > 0 else -e) * mx) >> sx
        ey = y - cy
        a = ay - ey
        a = ((a if a > 0 else -a) * my) >> sy
        if a > e:
            e = a
        ez = z - cz
        a = az - ez
        a = ((a if a > 0 else -a) * mz) >> sz
        if a > e:
            e = a
        # c stands out from both neighbours on an axis (same side of both) by the nearer
        # one, min(|c - p|, |c - n|) <= |2c - p - n| / 2: within spike_nt + allow by half
        # the largest bend, it stands out by no more (exact: floors keep the order). Else
        # (a spike, a sharp bend: a few a second) the stand-out itself, then the bend
        if e >> 1 > thr and self._stands_out(x, y, z):
            self.spikes += 1
            st[9] = -1     # its bend involved this spike
            # c is dropped; p stays p (the next judgement spans two periods, a little looser)
            st[0] = ax + ex
            st[1] = ay + ey
            st[2] = az + ez
            st[3] = x
            st[4] = y
            st[5] = z
            st[6] = t
            return False
        # the typical bend of the accepted stream: |2c - p - n| / 2, held as TYPICAL x it
        # (2 |2c - p - n|, the allowance's own unit), learnt one sample late, once the next
        # sample has passed too: a spike beside a good sample must not teach the screen to
        # allow spikes. The mean's step (p - allow) / 16 is rounded to the nearest unit
        # (halves up): +-0.5 unit a sample, at most 8 units (2**-9 nT) under the weight 15/16.
        # With allow = thr - sp: allow += (p - allow + 8) >> 4, on thr itself
        if pend >= 0:
            st[8] = thr + ((pend + sp - thr + 8) >> 4)
        st[9] = e + e
        self.x = cx
        self.y = cy
        self.z = cz
        self.t = ct
        st[0] = ex
        st[1] = ey
        st[2] = ez
        st[3] = x
        st[4] = y
        st[5] = z
        st[6] = t
        return True

    def _stands_out(self, x, y, z):
        """True when c (held) is a spike: it stands out (units, largest axis) past spike_nt +
        max(allow, the bend |v|^2 / (2 |h|)), v = n - p (two periods) and h = c."""
        _, _, _, mx, sx, my, sy, mz, sz = self._k
        ax, ay, az, cx, cy, cz, _, _, thr, _ = self._st
        d = _out(ax, cx - x, mx, sx)
        e = _out(ay, cy - y, my, sy)
        if e > d:
            d = e
        e = _out(az, cz - z, mz, sz)
        if e > d:
            d = e
        if d <= thr:
            return False
        # past the bend too: d - spike_nt > |v|^2 / (2 |h|). Exact: each axis in units of
        # 2**-g (its multiplier shifted to the common g bits), then, both sides positive,
        # (2 (d - spike) 2**g)^2 |h|^2 > (|v|^2)^2; big integers
        g = self._g
        mx <<= g - sx
        my <<= g - sy
        mz <<= g - sz
        hx = cx * mx
        hy = cy * my
        hz = cz * mz
        h2 = hx * hx + hy * hy + hz * hz
        if h2 == 0:         # no field to bend around: the bend is 0
            return True
        # n - p = (n - c) + (c - p)
        vx = (x - cx + ax) * mx
        vy = (y - cy + ay) * my
        vz = (z - cz + az) * mz
        v2 = vx * vx + vy * vy + vz * vz
        w = (d - self._spike) << (g + 1)
        return w * w * h2 > v2 * v2

