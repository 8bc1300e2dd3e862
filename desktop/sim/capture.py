"""Capture files (.npz) written by `fluxcal simulate`, read by `fluxcal fit/correct`.

Keys (N conversions; every array is per DRDY of the two chips, which coincide):

==================  ==============  ===============================================
key                 shape, dtype    meaning
==================  ==============  ===============================================
codes               (N, 4) int32    raw ADS1292 codes: chip A CH1 = X, CH2 = Y,
                                    chip B CH1 = Z, CH2 = die temperature (MUX=0100)
t                   (N,) float64    DRDY time, s since START
nT_per_code         (3,) float64    nominal front-end scale of X, Y, Z (nT per code)
registers           (2, 12) uint8   register maps of chip A and chip B
field_true          (N, 3) float64  true field in the sensor's orthogonal frame, nT
magnitude_true      (N,) float64    true |B| at the sensor, nT
quaternion          (N, 4) float64  sensor-to-world orientation (w, x, y, z)
position            (N, 3) float64  sensor position, m (world: x north, y east, z down)
temperature_c       (N,) float64    true temperature, C
sensor_matrix       (3, 3) float64  A in raw = A b + c (nominal nT, at 25 C)
sensor_offset       (3,) float64    c, nT
config              () str          JSON: every scenario setting, version, ticks
==================  ==============  ===============================================

``load_field_nT`` gives the uncalibrated readings codes[:, :3] * nT_per_code.
"""

import json

import numpy as np

from desktop.sim import ads1292 as ads

KEYS = ("codes", "t", "nT_per_code", "registers", "field_true", "magnitude_true",
        "quaternion", "position", "temperature_c", "sensor_matrix", "sensor_offset", "config")


def save_capture(path, capture):
    """Write a capture dict (as :func:`desktop.sim.scenario.simulate` returns) to .npz."""
    missing = [k for k in KEYS if k not in capture]
    if missing:
        raise KeyError("capture lacks %s" % ", ".join(missing))
    np.savez_compressed(path, **{k: np.asarray(capture[k]) for k in KEYS})


def load_capture(path):
    """Read a capture: dict of arrays, config decoded from JSON."""
    with np.load(path, allow_pickle=False) as z:
        missing = [k for k in ("codes", "nT_per_code") if k not in z.files]
        if missing:
            raise KeyError("missing keys %s" % ", ".join(missing))
        cap = {k: z[k] for k in z.files}
    if "config" in cap:
        cap["config"] = json.loads(str(cap["config"]))
    return cap


def field_nT(capture):
    """(N, 3) raw readings in nT (nominal scale) of a capture dict."""
    codes = np.asarray(capture["codes"])
    if codes.ndim != 2 or codes.shape[1] < 3:
        raise ValueError("codes must be (N, >=3)")
    return codes[:, :3].astype(float) * np.asarray(capture["nT_per_code"], dtype=float)


def load_field_nT(path):
    """(N, 3) float64 uncalibrated field readings in nT from a capture file."""
    return field_nT(load_capture(path))


def temperature_from_codes(capture):
    """(N,) die temperature (C) read back from chip B's CH2 codes [DS Eq.3]."""
    cfg = ads.Config(capture["registers"][1])
    volts = ads.codes_to_volts(capture["codes"][:, 3], cfg.gain[1], cfg.vref)
    return ads.volts_to_temperature(volts)


def write_csv(path, capture, decimate=1):
    """CSV in nT: header x,y,z,t,temperature_c,magnitude_true (every `decimate`-th row)."""
    h = field_nT(capture)[::decimate]
    cols = [h, capture["t"][::decimate, None], temperature_from_codes(capture)[::decimate, None],
            capture["magnitude_true"][::decimate, None]]
    np.savetxt(path, np.hstack(cols), delimiter=",", fmt="%.4f",
               header="x,y,z,t,temperature_c,magnitude_true", comments="")
