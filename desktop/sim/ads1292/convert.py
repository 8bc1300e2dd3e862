"""Conversion results of a continuously running ADS1292, vectorised over a capture.

    codes = convert(volts, None, config, first_tick=..., n=..., rng=rng)

The chip's sinc3 decimator is applied exactly on an analog grid of `step`
modulator ticks per sample, the MUX and PGA as the registers say, the ADC's
input-referred noise drawn in conversion order: the byte-level chip (chip.py)
computes its codes with this same function, so both paths agree code for code.
"""

import numpy as np

from desktop.sim.ads1292.registers import (AVDD, DVDD, F_MOD, FULL_SCALE_CODE, MUX_NORMAL,
                                           MUX_SUPPLY, MUX_TEMP, MUX_TEST, NOISE_UV_GAIN6,
                                           temperature_volts)


def noise_gain_factor(gain):
    """Input-referred ADC noise at `gain` relative to gain 6.

    Model noise(G) = sqrt(a^2 + (b/G)^2) fitted to the 500 SPS rows of [DS §7.1]
    (3.0 uV at G=1, 0.9 at G=6; it predicts 0.80 at G=12, the table says 0.8).
    """
    return np.sqrt(0.576 + 8.424 / gain ** 2) / 0.9


def sinc3_kernel(decimation, step, phase):
    """Weights of the sinc3 decimator on an analog grid coarser than fMOD.

    The chip's digital filter is three cascaded boxcars of `decimation` modulator
    samples (-3 dB at 0.262 fDR [DS Eq.5]): an impulse response of 3D - 2 taps.
    The emulator's analog input is held constant over `step` modulator ticks,
    so each grid sample's weight is the sum of the taps that fall on it.

    Parameters
    ----------
    decimation : int
        fMOD / fDR.
    step : int
        Modulator ticks per analog grid sample (divides 16).
    phase : int
        Tick of the conversion within its grid sample, 0 <= phase < step.

    Returns
    -------
    (J,) float64 array
        Weight of grid sample g_T - j, j = 0..J-1, where g_T holds the DRDY tick.
    """
    box = np.ones(decimation)
    taps = np.convolve(np.convolve(box, box), box)
    taps /= taps.sum()
    j = (np.arange(taps.size) - phase + step - 1) // step   # grid samples back
    return np.bincount(j, weights=taps)


def channel_input(x, mux, channel, cfg, temp_c, ticks, vref_scale=1.0):
    """Differential input (V) a channel sees for its MUX setting [DS §8.6.1.5].

    `x` is the sinc3-filtered analog input of the channel (V) and `temp_c` the
    filtered die temperature (C), both (N,) arrays at the conversion ticks;
    `vref_scale` the reference's drift (1 at 25 C), which the test signal follows.
    """
    if mux == MUX_NORMAL:
        return x
    if mux == MUX_TEMP:
        return temperature_volts(temp_c)
    if mux == MUX_SUPPLY:
        # CH1 reads (AVDD + AVSS) / 2, CH2 DVDD / 4 (text; the table is inconsistent).
        return np.full(x.shape, (AVDD / 2) if channel == 0 else (DVDD / 4))
    if mux == MUX_TEST and cfg.int_test:
        amp = cfg.vref * vref_scale / 2400.0                  # +-(VREFP - VREFN) / 2400
        if cfg.test_1hz:
            return np.where((ticks // (F_MOD // 2)) % 2 == 0, amp, -amp)
        return np.full(x.shape, amp)
    return np.zeros(x.shape)                                  # short, RLD, test off, IN3


def convert(volts, temp_c, cfg, *, first_tick=None, n=None, rng, step=8, grid_tick0=0,
            clipping=False, normals=None, ticks=None, vref_tempco=0.0):
    """Vectorised conversion results of a continuously running chip.

    Parameters
    ----------
    volts : (G, 2) float array, V
        Analog differential input of CH1, CH2 on a grid of `step` modulator
        ticks per sample starting at tick `grid_tick0`; held at the edges.
    temp_c : (G,) float array or float or None
        Die temperature (C) on the same grid (None: 25 C).
    cfg : Config
    first_tick : int
        Modulator tick of the first DRDY; later ones follow every decimation.
    n : int
        Number of conversions.
    ticks : (n,) int array or None
        Instead of `first_tick` and `n`: the DRDY tick of each conversion, in
        any spacing (a chip whose clock drifts, clock.py); each is the sinc3 of
        nominal length ending at its tick.
    rng : numpy.random.Generator
        Draws the ADC's input-referred noise, (n, 2) normals in conversion order.
    clipping : bool
        Fault injection: drive CH1 beyond positive full scale.
    normals : (n, 2) float array or None
        Standard normals for the noise, row i for conversion i; None draws them
        from `rng` (which is then not used). A Generator's normals come in the
        same order however they are split into calls, so codes computed from
        rows of one larger draw equal codes computed draw by draw.
    vref_tempco : float
        The internal reference's temperature coefficient, relative per C
        (|.| <= 45e-6 [DS §6.5]): VREF(T) = VREF (1 + vref_tempco (T - 25)) at
        the die temperature of each conversion, so every channel of the chip
        (the temperature sensor's too) reads V / VREF(T). 0: a reference that
        does not drift (the default; codes at 25 C are the same either way).

    Returns
    -------
    (n, 2) int32 array
        24-bit two's complement codes, clipped to [-2^23, 2^23 - 1].
    """
    d = cfg.decimation
    if d % step:
        raise ValueError("analog grid step %d does not divide decimation %d" % (step, d))
    if ticks is None:
        ticks = first_tick + np.arange(n, dtype=np.int64) * d
        phases = [(first_tick - grid_tick0) % step]             # one phase: regular spacing
    else:
        ticks = np.asarray(ticks, dtype=np.int64)
        n = len(ticks)
        phases = np.unique((ticks - grid_tick0) % step)
    volts = np.asarray(volts, dtype=float)
    last = volts.shape[0] - 1
    x = np.zeros((n, 2))
    t = np.zeros(n)
    temp = None if temp_c is None or np.ndim(temp_c) == 0 else np.asarray(temp_c, float)
    rel = ticks - grid_tick0
    for phase in phases:                                       # conversions by their phase in a grid sample
        sel = slice(None) if len(phases) == 1 else (rel % step == phase)
        w = sinc3_kernel(d, step, phase)
        g = rel[sel] // step                                   # grid sample of each DRDY
        xs, ts = x[sel], t[sel]
        for j, wj in enumerate(w):                             # taps, not samples
            idx = np.clip(g - j, 0, last)
            xs += wj * volts[idx]
            if temp is not None:
                ts += wj * temp[idx]
        x[sel], t[sel] = xs, ts
    if temp is None:
        t[:] = 25.0 if temp_c is None else float(temp_c)
    if normals is None:
        normals = rng.standard_normal((n, 2))
    noise = normals * (NOISE_UV_GAIN6[min(cfg.dr, 6)] * 1e-6)
    # the reference at each conversion's die temperature; exactly 1 at 25 C or without drift
    vs = 1.0 + vref_tempco * (t - 25.0) if vref_tempco else 1.0
    out = np.zeros((n, 2), dtype=np.int32)
    for ch in range(2):
        if cfg.power_down[ch]:
            continue                                           # reads 0, keeps its slot [DS §8.5.1.5]
        v = channel_input(x[:, ch], cfg.mux[ch], ch, cfg, t, ticks, vs)
        if clipping and ch == 0:
            v = v + 2.0 * cfg.vref / cfg.gain[ch]
        v = v + noise[:, ch] * noise_gain_factor(cfg.gain[ch])
        if vref_tempco:
            v = v / vs
        code = np.rint(v * (cfg.gain[ch] * FULL_SCALE_CODE / cfg.vref))
        out[:, ch] = np.clip(code, -(1 << 23), FULL_SCALE_CODE)  # clips at +-FS [DS §8.3.8]
    return out


class _NoNoise:
    """Stands in for a Generator when the ADC's noise is switched off."""

    @staticmethod
    def standard_normal(shape):
        return np.zeros(shape)


NO_NOISE = _NoNoise()
