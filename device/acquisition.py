"""Decimated samples out of the DRDY ring (main loop side).

    dec = Decimator(adc, decim=20, window=5)   # sets the ISR's boxcar (ads1292.set_decimation)
    n = dec.poll(on_sample, limit)             # on_sample(sx, sy, sz, st) per sample

Each sample is the integer SUM of the last `window` frames of a block of
`decim` frames, computed in the DRDY handler (ads1292.py): exact (no division,
no float), in units of codes*window.
Why a short window: a vector averaged over a rotation arc of angle a shrinks by
sin(a/2)/(a/2) ~ 1 - a**2/24; at 1 rev/s a 2.5 ms window biases |B| by
48000 nT * (2*pi*0.0025)**2/24 = 0.49 nT, a 0.1 s window by 1.6 % (docs/simulator.md).
Why decimate by more than the window: the calibration path costs ~30x the
acquisition path per sample, and the fit needs a few thousand samples, not
hundreds of thousands (docs/firmware.md, the sweep).

Continuity: every ring slot carries the handler's block number; a jump means
blocks were lost (ring overflow, or blocks discarded for a bad frame or a
polled-DRDY gap). It is
counted in `gaps` and reported to `on_gap` so the calibration does not
compare two samples that are not neighbours in time.
"""

from ads1292 import DISCARDED

_MASK30 = 0x3FFFFFFF


class Decimator:
    def __init__(self, adc, decim=8, window=4):
        adc.set_decimation(decim, window)   # ValueError names a bad pair
        self.adc = adc
        self.decim = decim
        self.window = window
        self.samples = 0      # decimated samples delivered
        self.gaps = 0         # discontinuities seen in the block numbers
        self._last = -1

    @property
    def discarded(self):
        """Blocks thrown away for a bad status header or a DRDY gap (polled DRDY)."""
        return self.adc.state[DISCARDED]

    def poll(self, on_sample, limit=16, on_gap=None):
        """Deliver up to `limit` samples from the ring; return the number delivered."""
        adc = self.adc
        ring = adc.ring
        n = 0
        while n < limit:
            j = adc.pop_index()
            if j < 0:
                break
            sx = ring[j]
            sy = ring[j + 1]
            sz = ring[j + 2]
            st = ring[j + 3]
            blk = ring[j + 4]
            adc.release()
            if self._last >= 0 and blk != ((self._last + 1) & _MASK30):
                self.gaps += 1
                if on_gap is not None:
                    on_gap()
            self._last = blk
            n += 1
            self.samples += 1
            on_sample(sx, sy, sz, st)
        return n
