"""Decimated samples the fit and the survey must not see: one-sample spikes and clipped ones.

    sc = Screen(scale, window, spike_nt)
    if sc.push(sx, sy, sz, st):      # one sample late: judges the one before
        use(sc.x, sc.y, sc.z, sc.t)
    sc.reset()                       # after a gap in the stream: neighbours are not neighbours

A flipped data bit (a noisy SPI line: [DS] checks nothing but the status nibble)
moves one frame's code by 2**k; in a boxcar sum it shows as one sample off the
line through its neighbours, and back. The field cannot do that: a rotating
vector bends by |v|**2 / |h| per sample (centripetal), a turning hand adds
B alpha dt**2 at a reversal, and a real step (walking over iron) stays.
So sample i is a spike when it departs from BOTH neighbours in the SAME
direction by more than that bend plus a threshold:
    min(|x_i - x_(i-1)|, |x_i - x_(i+1)|) > spike_nt + max(TYPICAL * typical, 2 |v|**2 / |h|)
on one axis (nT), with TYPICAL = 4 and `typical` a running mean of that same quantity
(it is large while the hand reverses quickly, noise-sized at rest). A step
fails the test (x_i equals its next neighbour); smooth motion fails it
(the two differences have opposite signs). A false alarm costs one sample;
a spike let through costs nT in the survey (docs/reliability.md has both rates).

Clipped: a boxcar of full-scale codes ([DS 8.3.8] saturates at 0x7FFFFF / 0x800000)
means the sensor or the PGA gain exceeds the ADC's range; the sample is not
the field (session.py names it `clipped` when it happens during a calibration).
"""

CLIP_CODES = 8323072   # 2**23 - 2**16: within 0.8 % of full scale
TYPICAL = 4.0          # times the running mean bend a sample may stand out by


class Screen:
    def __init__(self, scale, window, spike_nt):
        # nT per sum unit, per axis
        self.k = (scale[0] / window, scale[1] / window, scale[2] / window)
        self.clip = CLIP_CODES * window
        self.spike_nt = spike_nt
        self.spikes = 0      # samples rejected as spikes
        self.clipped = 0     # samples rejected as clipped
        self.clip_axis = None   # the axis of the last one (0, 1, 2)
        self.reset()

    def reset(self):
        """Forget the held samples (a gap: the next one has no neighbour)."""
        self._n = 0          # samples held: 0, 1 (c) or 2 (p, c)
        self._typ = 0.0
        self._pending = -1.0   # the last accepted sample's bend, not yet learnt (< 0: none)

    def push(self, x, y, z, t):
        """Take the next sample; True when the one before it is good (it is then in .x .y .z .t)."""
        c = self.clip
        if x >= c or x <= -c or y >= c or y <= -c or z >= c or z <= -c:
            self.clipped += 1
            self.clip_axis = 0 if (x >= c or x <= -c) else (1 if (y >= c or y <= -c) else 2)
            self.reset()     # a clipped sample is no neighbour either
            return False
        n = self._n
        good = False
        if n == 2:
            k = self.k
            cx = self._cx
            cy = self._cy
            cz = self._cz
            # how far c stands out from both neighbours on each axis (nT; 0 unless on the same
            # side of both), the largest of the three; written out, no call per axis
            a = cx - self._px
            e = cx - x
            d = (a if a < e else e) * k[0] if a > 0 and e > 0 else (
                -(a if a > e else e) * k[0] if a < 0 and e < 0 else 0.0)
            a = cy - self._py
            e = cy - y
            e = (a if a < e else e) * k[1] if a > 0 and e > 0 else (
                -(a if a > e else e) * k[1] if a < 0 and e < 0 else 0.0)
            if e > d:
                d = e
            a = cz - self._pz
            e = cz - z
            e = (a if a < e else e) * k[2] if a > 0 and e > 0 else (
                -(a if a > e else e) * k[2] if a < 0 and e < 0 else 0.0)
            if e > d:
                d = e
            allow = TYPICAL * self._typ
            # The bend |v|^2 / |h| only raises the allowance, and a rounded sum never falls as a
            # term grows: a sample within spike_nt + TYPICAL * typical passes whatever the bend,
            # so its ten float operations run only for the few that stand out that far.
            if d > self.spike_nt + allow:
                # |v|^2 / |h| in nT: v from the outer neighbours, over two periods
                vx = (x - self._px) * k[0]
                vy = (y - self._py) * k[1]
                vz = (z - self._pz) * k[2]
                hx = cx * k[0]
                hy = cy * k[1]
                hz = cz * k[2]
                h2 = hx * hx + hy * hy + hz * hz
                bend = 0.5 * (vx * vx + vy * vy + vz * vz) / (h2 ** 0.5) if h2 > 0 else 0.0
                if bend > allow:
                    allow = bend
                if d > self.spike_nt + allow:
                    self.spikes += 1
                    self._pending = -1.0   # its bend involved this spike
                    # c is dropped; p stays p (the next judgement spans two periods, a little looser)
                    self._cx = x
                    self._cy = y
                    self._cz = z
                    self._ct = t
                    return False
            # the typical bend of the accepted stream: |2c - p - n| / 2, largest axis
            e = cx + cx - self._px - x
            e = (e if e > 0 else -e) * k[0]
            f = cy + cy - self._py - y
            f = (f if f > 0 else -f) * k[1]
            if f > e:
                e = f
            f = cz + cz - self._pz - z
            f = (f if f > 0 else -f) * k[2]
            if f > e:
                e = f
            # learnt one sample late, once the next sample (in e) has passed too: a spike
            # beside a good sample must not teach the screen to allow spikes
            if self._pending >= 0.0:
                self._typ += (self._pending - self._typ) * 0.0625
            self._pending = 0.5 * e
            good = True
            self.x = cx
            self.y = cy
            self.z = cz
            self.t = self._ct
        if n >= 1:
            self._px = self._cx
            self._py = self._cy
            self._pz = self._cz
        self._cx = x
        self._cy = y
        self._cz = z
        self._ct = t
        self._n = n + 1 if n < 2 else 2
        return good

