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
sensor_matrix       (3, 3) float64  A in raw = A b + c (nominal nT, at 25 C)
sensor_offset       (3,) float64    c, nT
config              () str          JSON: every scenario setting, version, ticks
==================  ==============  ===============================================

With the truth (`fluxcal simulate --truth`), also:

==================  ==============  ===============================================
field_true          (N, 3) float64  true field in the sensor's orthogonal frame, nT
magnitude_true      (N,) float64    true |B| at the sensor, nT
quaternion          (N, 4) float64  sensor-to-world orientation (w, x, y, z)
position            (N, 3) float64  sensor position, m (world: x north, y east, z down)
temperature_c       (N,) float64    true temperature, C
==================  ==============  ===============================================

A walked survey (`fluxcal simulate --motion survey`) also has

==================  ==============  ===============================================
line_marks          (L, 2) float64  the marker pressed at each traverse's start and end, s
==================  ==============  ===============================================

and its config's "survey" names the grid (width_m east, length_m north,
spacing_m, zigzag, ...), which `fluxcal map` reads.

A recording from a handheld (`fluxcal capture`, the firmware's `raw` stream)
has no chip registers and no truth; its samples are the firmware's decimated
samples (the mean codes of each boxcar), not single conversions:

==================  ==============  ===============================================
codes               (N, 3) float64  mean raw codes of X, Y, Z per sample
t                   (N,) float64    device time of each output, s since the first (ms steps;
                                    samples sent in one pass of the main loop may share one)
nT_per_code         (3,) float64    the device's front-end scale (config scale_x/y/z)
die_temperature_c   (N,) float64    ADS1292 die temperature, C (as the device reports)
config              () str          JSON: the device's version reply, config, port
==================  ==============  ===============================================

Stored without compression: ADC codes are noise in their low bits, so zlib
saves 40 % of the file at 25 times the cost of writing it (a 10 min capture
at 4000 SPS: 58 MB in 0.1 s, or 35 MB in 2.5 s). ``field_nT`` gives the
uncalibrated readings codes[:, :3] * nT_per_code.
"""

import json

import numpy as np

from desktop.formats import FormatError, os_problem
from desktop.sim.ads1292.registers import Config, codes_to_volts, volts_to_temperature

KEYS = ("codes", "t", "nT_per_code", "registers", "sensor_matrix", "sensor_offset", "config")
TRUTH_KEYS = ("field_true", "magnitude_true", "quaternion", "position", "temperature_c")
SURVEY_KEYS = ("line_marks",)


def save_capture(path, capture):
    """Write a capture dict (desktop.sim.scenario.simulate) to .npz, truth keys if present."""
    missing = [k for k in KEYS if k not in capture]
    if missing:
        raise ValueError("capture lacks %s" % ", ".join(missing))
    keys = KEYS + tuple(k for k in TRUTH_KEYS + SURVEY_KEYS if k in capture)
    _savez(path, {k: np.asarray(capture[k]) for k in keys})


def save_recording(path, codes, t, nT_per_code, die_temperature_c, config):
    """Write a handheld's recording (keys above); `config` is a JSON-ready dict."""
    arrays = {"codes": np.asarray(codes, dtype=float).reshape(-1, 3), "t": np.asarray(t, dtype=float),
              "nT_per_code": np.asarray(nT_per_code, dtype=float),
              "die_temperature_c": np.asarray(die_temperature_c, dtype=float),
              "config": np.array(json.dumps(config))}
    _savez(path, arrays)


def _savez(path, arrays):
    try:
        with open(path, "wb") as fh:
            np.savez(fh, **arrays)
    except OSError as exc:
        raise FormatError("%s: %s" % (path, exc.strerror or exc))


def load_capture(path):
    """Read a capture: dict of arrays, config decoded from JSON. FormatError if it is none."""
    try:
        with open(path, "rb") as fh:
            if fh.read(2) != b"PK":    # an .npz is a zip; numpy would read anything else as a pickle
                raise FormatError("%s: not a fluxcal capture (not an .npz: fluxcal simulate, capture and survey "
                                  "write them)" % path)
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in ("codes", "nT_per_code") if k not in z.files]
            if missing:
                raise FormatError("%s: not a fluxcal capture (no %s)" % (path, ", ".join(missing)))
            cap = {k: z[k] for k in z.files}
        if "config" in cap:
            cap["config"] = json.loads(str(cap["config"]))
    except OSError as exc:
        raise FormatError(os_problem(path, exc))
    except (ValueError, EOFError) as exc:
        raise FormatError("%s: not a fluxcal capture (%s)" % (path, exc))
    return cap


def field_nT(capture):
    """(N, 3) raw readings in nT (nominal scale) of a capture dict."""
    codes = np.asarray(capture["codes"])
    if codes.ndim != 2 or codes.shape[1] < 3:
        raise FormatError("codes must be (N, >=3), got %s" % (codes.shape,))
    return codes[:, :3].astype(float) * np.asarray(capture["nT_per_code"], dtype=float)


def load_field_nT(path):
    """(N, 3) float64 uncalibrated field readings in nT from a capture file."""
    return field_nT(load_capture(path))


def temperature_from_codes(capture):
    """(N,) die temperature (C) read back from chip B's CH2 codes [DS Eq.3], or as a handheld reported it."""
    if "die_temperature_c" in capture:
        return np.asarray(capture["die_temperature_c"], dtype=float)
    cfg = Config(capture["registers"][1])
    return volts_to_temperature(codes_to_volts(capture["codes"][:, 3], cfg.gain[1], cfg.vref))


def write_csv(path, capture, decimate=1):
    """CSV in nT: x,y,z,t,temperature_c (die, from the codes), and magnitude_true with the truth."""
    cols = [field_nT(capture)[::decimate], capture["t"][::decimate, None],
            temperature_from_codes(capture)[::decimate, None]]
    names = "x,y,z,t,temperature_c"
    if "magnitude_true" in capture:
        cols.append(capture["magnitude_true"][::decimate, None])
        names += ",magnitude_true"
    try:
        np.savetxt(path, np.hstack(cols), delimiter=",", fmt="%.4f", header=names, comments="")
    except OSError as exc:
        raise FormatError("%s: %s" % (path, exc.strerror or exc))
