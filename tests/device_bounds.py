"""Headline bounds for the firmware's verification spin, derived from the physics.

The firmware streams |h_c| averaged over blocks (survey_hz); after a good
calibration a 360 degree spin shows only
- noise: per frame the ADS1292's input-referred noise at the data rate and
  gain 1 [DS §7.1] and the sensor's white noise, averaged over the frames of a
  block (window frames per decimated sample x samples per block); the range of
  n such blocks is at most its mean + 4 standard deviations (of the range of n
  Gaussian samples, computed here);
- the smearing the rate gate admits: a vector turning at the gate's rate over a
  boxcar of T = window / rate is shortened by B (omega T)^2 / 24 (docs/simulator.md);
  samples carry 0 up to that bias, the fit absorbs its mean, half remains.
"""

import numpy as np

from desktop.firmware.files import import_device
from desktop.sim.ads1292.convert import noise_gain_factor
from desktop.sim.ads1292.registers import DATA_RATES, FULL_SCALE_CODE, NOISE_UV_GAIN6, VREF_LOW

# the firmware's own defaults (device/config.py), so a bound follows a change of them
DEFAULTS = {k: import_device("config").SCHEMA[k][0] for k in ("rate", "decim", "window", "survey_hz", "gate_rate_dps")}


def block_sigma(scenario, cfg=None):
    """rms noise of one output block of |h_c|, nT."""
    c = dict(DEFAULTS, **(cfg or {}))
    lsb_nt = scenario.nt_per_code()[0]
    adc_v = NOISE_UV_GAIN6[DATA_RATES.index(c["rate"])] * 1e-6 * noise_gain_factor(1)
    frame = np.hypot(adc_v / (VREF_LOW / FULL_SCALE_CODE) * lsb_nt, scenario.noise)
    frames = c["window"] * (c["rate"] / c["decim"]) / c["survey_hz"]
    return frame / np.sqrt(frames)


def range_bound(n, sds=4.0):
    """Mean + sds standard deviations of the range of n standard normal samples."""
    r = np.ptp(np.random.default_rng(0).standard_normal((20000, n)), axis=1)
    return r.mean() + sds * r.std()


def spin_ptp_bound(scenario, n_blocks, cfg=None):
    """Largest PTP (nT) of a well-calibrated spin's n_blocks outputs: noise range + half the smearing."""
    c = dict(DEFAULTS, **(cfg or {}))
    turn = np.radians(c["gate_rate_dps"]) * c["window"] / c["rate"]
    smear = scenario.field_nT * turn ** 2 / 24.0
    return range_bound(n_blocks) * block_sigma(scenario, c) + 0.5 * smear
