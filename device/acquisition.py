"""Boxcar decimation of ADS1292 frames into fit-rate samples (main loop only).

    dec = Decimator(adc, decim=8, window=4)
    n = dec.poll(on_sample, limit)  # calls on_sample(sx, sy, sz, st, n) per output

Each output is the integer SUM of the last `window` frames of every block of
`decim` frames: exact (no division, no float), and in units of codes*window.
Why a short window: a vector averaged over a rotation arc of angle a shrinks by
sin(a/2)/(a/2) ~ 1 - a**2/24; at 1 rev/s a 2 ms window (4 frames at 2000 SPS)
biases |B| by 50000 nT * (2*pi*0.002)**2/24 = 0.33 nT, a 0.1 s window by 1.6 %.
Why decimate at all: the calibration path costs ~100x the acquisition path per
sample, and the fit needs hundreds, not hundreds of thousands, of samples.

Continuity: every ring slot carries the ISR's frame number; a block that spans
a gap (ring overflow or a bad status header) is discarded, so no output ever
mixes two different moments.
"""

_MASK30 = 0x3FFFFFFF


class Decimator:
    def __init__(self, adc, decim=8, window=4):
        if not 1 <= window <= decim:
            raise ValueError("window %r must be within 1..decim (%r)" % (window, decim))
        self.adc = adc
        self.decim = decim
        self.window = window
        self.samples = 0      # decimated samples emitted
        self.discarded = 0    # blocks thrown away across a gap
        self.gaps = 0         # discontinuities seen in the frame numbers
        self.restart()

    def restart(self):
        self._i = 0
        self._sx = self._sy = self._sz = self._st = 0
        self._last = -1

    def poll(self, on_sample, limit=64):
        """Drain up to `limit` frames from the ring; return frames consumed."""
        adc = self.adc
        ring = adc.ring
        first = self.decim - self.window
        n = 0
        while n < limit:
            j = adc.pop_index()
            if j < 0:
                break
            fno = ring[j + 4]
            if self._last >= 0 and fno != ((self._last + 1) & _MASK30):
                # frames were lost before this one: the open block is not contiguous
                self.gaps += 1
                if self._i:
                    self.discarded += 1
                self._i = 0
                self._sx = self._sy = self._sz = self._st = 0
            self._last = fno
            i = self._i
            if i >= first:
                self._sx += ring[j]
                self._sy += ring[j + 1]
                self._sz += ring[j + 2]
                self._st += ring[j + 3]
            adc.release()
            n += 1
            i += 1
            if i == self.decim:
                self.samples += 1
                sx, sy, sz, stt = self._sx, self._sy, self._sz, self._st
                self._sx = self._sy = self._sz = self._st = 0
                self._i = 0
                on_sample(sx, sy, sz, stt)
            else:
                self._i = i
        return n
