"""The analog world feeding one emulated ADS1292: inputs, die temperature, noise.

:class:`AnalogInput` holds what the chip's front end sees over time (the two
differential inputs on a uniform grid, the die temperature, the reference's
drift) and turns it into codes through convert.py, the vectorised path, so a
capture and a byte-level run of the same grid agree code for code. It knows
nothing of SPI, commands or pins: the chip (chip.py) asks it for the codes of
the conversions its schedule (clock.py) says complete.
"""

import numpy as np

from desktop.sim.ads1292.convert import NO_NOISE, convert
from desktop.sim.ads1292.registers import F_MOD


class AnalogInput:
    """The inputs, temperature and noise of one chip, and the codes they convert to.

    Parameters
    ----------
    rng : numpy.random.Generator
        The ADC noise's stream (settable: the noise is drawn from the new Generator from then on).
    noise : bool
        False: no input-referred noise (an ideal converter, for tests).
    vref_tempco : float
        The internal reference's drift, relative per C about 25 C (within
        +-45e-6 [DS §6.5]; see :func:`convert`); 0: none.
    batch : int
        Conversions computed per vectorised :func:`convert` call (see :attr:`batch`).
    """

    def __init__(self, rng, *, noise=True, vref_tempco=0.0, batch=1):
        self.rng = rng
        self.noise = noise
        self.vref_tempco = float(vref_tempco)
        self.temperature_c = 25.0      # die temperature when no source is loaded
        self.volts = np.zeros((1, 2))  # (G, 2) V, the loaded grid
        self.temp = None               # (G,) C on the grid, or None: temperature_c
        self.step, self.grid_tick0 = 8, 0   # grid spacing and first sample, modulator ticks
        self._cache = None             # batched codes, see codes()
        self._normals = np.zeros((0, 2))   # noise normals drawn ahead of use, see _peek_normals
        self._normals_off = 0          # of which this many rows are consumed already
        self._normals_rng = self.rng
        self._normals_used = 0         # rows of normals consumed since power-up
        self.batch = batch

    @property
    def batch(self):
        """Conversions computed ahead per vectorised :func:`convert` call (int >= 1).

        One `convert` call costs ~0.5 ms whatever its length, so computing each
        conversion when its DRDY comes due limits the byte path to ~2000
        frames/s. With `batch` > 1, when a conversion comes due the chip
        computes it and up to `batch` - 1 of its successors (no further than
        the loaded grid reaches) and serves them from a cache while the
        register map, the analog input (:meth:`load`, `temperature_c`),
        `noise`, `fault` and the conversion schedule stay the same; anything
        else recomputes. The noise normals are drawn from `rng` ahead of use
        and consumed in conversion order, so the codes, DRDY ticks, frames,
        faults and violations equal those of `batch` = 1 exactly; only
        `rng`'s state runs ahead (do not share the Generator with anything
        else). Settable at any time; single-shot conversions are never
        batched. The loaded `volts` must not be changed in place (call
        :meth:`load` again).
        """
        return self._batch

    @batch.setter
    def batch(self, n):
        if int(n) != n or n < 1:
            raise ValueError("batch must be an integer >= 1, got %r" % (n,))
        self._batch = int(n)
        self._cache = None

    def drop_cache(self):
        """Forget the batched codes (something they depend on changed)."""
        self._cache = None

    def load(self, volts, rate_hz=16000, t0=0.0, temperature_c=None):
        """Feed the analog inputs over time.

        Parameters
        ----------
        volts : (G, 2) array, V
            Differential inputs of CH1 and CH2 on a uniform grid.
        rate_hz : int
            Grid rate; must be fMOD / step with step in 1, 2, 4, 8, 16
            (128k, 64k, 32k, 16k, 8k) so every data rate sees whole samples.
        t0 : float
            Chip time (s) of the first sample; before / after the grid the
            first / last sample is held.
        temperature_c : (G,) array or float or None
            Die temperature (C) seen by MUX=0100.
        """
        step = F_MOD // int(rate_hz)
        if step * int(rate_hz) != F_MOD or 16 % step:
            raise ValueError("rate_hz must be 128 kHz / (1, 2, 4, 8 or 16), got %r" % rate_hz)
        volts = np.asarray(volts, dtype=float)
        if volts.ndim != 2 or volts.shape[1] != 2 or volts.shape[0] == 0:
            raise ValueError("volts must be a non-empty (G, 2) array")
        self.volts, self.step = volts, step
        self.grid_tick0 = int(round(t0 * F_MOD))
        self._cache = None
        if temperature_c is not None and np.ndim(temperature_c) == 0:
            self.temperature_c, self.temp = float(temperature_c), None
        else:
            self.temp = None if temperature_c is None else np.asarray(temperature_c, float)

    def codes(self, cfg, regs, schedule, n, single, clipping):
        """The codes [CH1, CH2] of the last of the next n conversions of `schedule` (own
        ticks m_next + i * decimation, i < n); the n conversions' noise rows are consumed.

        `cfg` is the register map `regs` (a tuple) decoded; `clipping`: the "clipping"
        fault is on. Served from the batch cache when it holds them, was computed for
        the same inputs, clock and schedule and its noise rows are the next unused
        ones; else computed with up to `batch` conversions ahead (see :attr:`batch`).
        """
        d = cfg.decimation
        m0 = schedule.m_next
        # everything convert() reads besides the tick and the noise rows
        key = (regs, self.step, self.grid_tick0, self.noise, clipping,
               None if self.temp is not None else self.temperature_c, schedule.anchor, schedule.num,
               schedule.den, self.vref_tempco)
        c = self._cache
        if c is not None and c[0] == key and c[1] is self.volts and c[2] is self.temp \
                and self._normals_rng is self.rng:
            i, r = divmod(m0 - c[3], d)
            rows = c[5]
            if r == 0 and i >= 0 and i + n <= len(rows) and c[4] + i == self._normals_used:
                self._take_normals(n)
                return rows[i + n - 1]
        m = n
        if self._batch > 1 and not single:      # single shot: the next START restarts the filter
            grid_end = self.grid_tick0 + (len(self.volts) - 1) * self.step
            m = max(n, min(self._batch, schedule.due_by(grid_end, d)))
        kw = dict(first_tick=schedule.nominal_tick(m0), n=m)
        if schedule.drifting:   # the conversions' nominal ticks, on whole ticks (a sinc3 window of nominal length)
            kw = dict(ticks=schedule.nominal_tick(m0 + d * np.arange(m, dtype=np.int64)))
        temp = self.temp if self.temp is not None else self.temperature_c
        codes = convert(self.volts, temp, cfg, step=self.step,
                        rng=NO_NOISE, normals=self._peek_normals(m) if self.noise else None,
                        grid_tick0=self.grid_tick0, clipping=clipping,
                        vref_tempco=self.vref_tempco, **kw)
        rows = codes.tolist()                   # Python ints: a frame is built from one row
        self._cache = (key, self.volts, self.temp, m0, self._normals_used, rows) if m > n else None
        self._take_normals(n)
        return rows[n - 1]

    def _peek_normals(self, m):
        """The next `m` rows of noise normals from `rng`, not yet consumed: (m, 2)."""
        if self._normals_rng is not self.rng:   # rng replaced: draw from the new one
            self._normals, self._normals_rng, self._cache = np.zeros((0, 2)), self.rng, None
            self._normals_off = 0
        if self._normals_off:                   # drop the consumed rows
            self._normals, self._normals_off = self._normals[self._normals_off:], 0
        short = m - len(self._normals)
        if short > 0:
            # draws exactly what is missing: with batch = 1 this is the unbatched draw
            self._normals = np.concatenate([self._normals, self.rng.standard_normal((short, 2))])
        return self._normals[:m]

    def _take_normals(self, n):
        """Consume `n` rows of normals (the conversions they belong to happened)."""
        if self.noise:
            self._normals_off += n
        self._normals_used += n
