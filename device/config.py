"""Board configuration: one JSON file (config.json) over documented defaults.

    cfg, problems = from_dict(body)       # defaults, overlaid with body's valid entries
    value = check(key, value)             # one key, or ValueError naming the problem
    cross_check(cfg)                      # relations between keys (window <= decim, ...)
    changed(cfg)                          # what config.json stores: the non-defaults

Every key has a default, a type and a range; from_dict keeps the default for
anything missing or invalid and reports it, so a bad file never stops the
device. docs/firmware.md lists the keys and why each default was chosen.
"""

from shared.codes import MAX_PREDICTED_NT   # fluxcal fit refuses by the same default

# key: (default, kind, lo, hi). kind: "int", "float", "bool", "bool_auto" (true, false or "auto"),
# "pin", "scale", "opt_float", "choice:a|b"
SCHEMA = {
    # wiring (pin names are HAL specific: GPIO numbers on MicroPython, board names on CircuitPython)
    "spi_id": (0, "int", 0, 3),
    "pin_sck": (18, "pin", 0, 0),
    "pin_mosi": (19, "pin", 0, 0),
    "pin_miso": (16, "pin", 0, 0),
    "pin_cs0": (17, "pin", 0, 0),
    "pin_cs1": (20, "pin", 0, 0),
    "pin_drdy": (21, "pin", 0, 0),
    "pin_start": (22, "pin", 0, 0),
    "pin_reset": (26, "pin", 0, 0),
    "pin_button": (15, "pin", 0, 0),
    "pin_led": (25, "pin", 0, 0),
    # ADC: 1000 SPS, every conversion a DRDY interrupt. At 2000 SPS the handler alone
    # took 43 % of the calibrating firmware's instructions on a Cortex-M
    # (python -m desktop.bench.cortexm); 1000 SPS halves it, with the same noise per
    # decimated sample (gain 6: 1.3 uVrms / sqrt 2 against 2.2 / sqrt 5, [DS] §7.1) and
    # the same spin accuracy in the simulator (docs/firmware.md, sweep).
    "rate": (1000, "int", 125, 8000),
    "gain_x": (1, "int", 1, 12),
    "gain_y": (1, "int", 1, 12),
    "gain_z": (1, "int", 1, 12),
    "vref_4v": (False, "bool", 0, 0),
    # front end: nT per ADC code per axis = (VREF / (2^23 - 1) / gain) / (V per nT at the pin).
    # Default: the reference front end (docs/simulator.md, the simulated handheld's):
    # Mag649 (0.1 V/uT, +-10 V) through a 5:1 divider onto +-2 V, gain 1, 2.42 V:
    # 2.885e-7 V / 2e-5 V/nT = 0.0144243258 nT/code (full scale +-121 uT).
    "scale_x": (0.0144243258, "float", 1e-6, 1e3),
    "scale_y": (0.0144243258, "float", 1e-6, 1e3),
    "scale_z": (0.0144243258, "float", 1e-6, 1e3),
    # decimation: a 2-frame (2 ms) boxcar every 10 frames -> 100 samples/s to the
    # gates. The smearing experiment (docs/simulator.md): a ~2 ms boxcar + a 1 rev/s
    # gate scores like fitting every conversion; the fit needs a few thousand
    # samples, not 400/s. The sweep in docs/firmware.md (python -m desktop.bench.device,
    # python -m desktop.bench.cortexm): more samples per second cost the gates and the
    # fit in proportion for little accuracy. window <= 64 keeps the handler's sums
    # below 2**30.
    "decim": (10, "int", 1, 256),
    "window": (2, "int", 1, 64),
    # calibration
    "field_nt": (None, "opt_float", 1000.0, 100000.0),  # local field if known (e.g. IGRF)
    "field_tol": (0.05, "float", 0.001, 0.5),     # accepted |fitted/configured - 1|
    "gate_rate_dps": (360.0, "float", 10.0, 5000.0),  # rotation-rate gate: 1 rev/s (smearing)
    # the sensor's -3 dB bandwidth (Mag649 1 kHz, Mag648 5 Hz): its lag shrinks |B| by
    # (tau w)^2 / 2 while turning, so the gate comes down to keep that under lag_tol_nt
    # (gates.py gate_dps; docs/experiments/lag.md)
    "sensor_bandwidth_hz": (1000.0, "float", 0.1, 100000.0),
    "lag_tol_nt": (0.5, "float", 0.001, 100.0),
    # where that lag would bring the gate under gate_rate_dps, the firmware undoes it instead
    # (shared/delag.py: before the gates, the fit and the survey), and the gate then follows
    # what is left: the configured tau's relative uncertainty response_tol (gates.py gate_dps)
    "delag": (True, "bool", 0, 0),
    # de-lag by the whole response, the ADC's sinc3 and the boxcar included, and so every sensor,
    # a fast one too (shared/delag.py response_tau_s). "auto": on, where the board's DRDY is an
    # interrupt and where it is polled (CircuitPython: its one-sample gaps are bridged, Delag.join)
    "delag_adc": ("auto", "bool_auto", 0, 0),
    "response_tol": (0.05, "float", 0.0, 1.0),
    # de-lagged: estimate tau at the finish (shared/tausums.py; four more sums per accepted
    # sample, a few more solves at the end) and use it, with its own uncertainty
    "tau_estimate": (True, "bool", 0, 0),
    "quick_min_coverage": (0.1, "float", 0.01, 1.0),  # a quick re-calibration auto-finishes here
    # calibrations this far apart in temperature give the offsets' and gains' coefficients
    "tempco_min_span_c": (2.0, "float", 0.5, 100.0),
    "cells": (4, "int", 2, 12),                   # 6*cells^2 coverage cells
    "cell_cap": (24, "int", 1, 10000),            # samples per cell into the fit
    "min_coverage": (0.5, "float", 0.05, 1.0),    # to allow auto-finish
    "target_error_nt": (1.0, "float", 0.01, 1000.0),  # predicted error to auto-finish
    "auto_finish": (True, "bool", 0, 0),
    "max_rms_nt": (5.0, "float", 0.01, 10000.0),  # acceptance: fit residual
    "min_observability": (0.02, "float", 0.0, 1.0),
    "max_predicted_nt": (MAX_PREDICTED_NT, "float", 0.01, 10000.0),
    "outlier_nt": (50.0, "float", 1.0, 100000.0),  # disturbance gate vs provisional fit
    # a decimated sample off the line through both neighbours by more than this (plus the
    # bend the motion allows) is a flipped bit, not the field (screen.py, docs/reliability.md)
    "spike_nt": (30.0, "float", 1.0, 100000.0),
    "solve_every_s": (5, "int", 1, 600),          # provisional solve period
    "max_cal_s": (300, "int", 10, 3600),
    # survey
    "survey_hz": (10, "int", 1, 100),             # output rate (0.1 s average, paper IV.C)
    "temp_warn_c": (5.0, "float", 0.1, 100.0),
    "log": (False, "bool", 0, 0),
    "log_file_bytes": (65536, "int", 1024, 10000000),
    "log_files": (4, "int", 1, 100),
    "log_reserve_bytes": (65536, "int", 0, 100000000),
    "stream": ("off", "choice:off|raw|corrected", 0, 0),
    # the watchdog (boards with one the firmware can hand back, hal_micropython.py): a main-loop
    # pass longer than this resets the board. The longest legitimate pass, the final solve, takes
    # about 0.5 s on an RP2040; 8388 ms is the RP2040's longest timeout. Read at boot.
    "watchdog_ms": (5000, "int", 1000, 8388),
}


def check(key, value):
    """Return the validated value or raise ValueError naming the key and the problem."""
    if key not in SCHEMA:
        raise ValueError("unknown config key %r" % (key,))
    default, kind, lo, hi = SCHEMA[key]
    if kind == "bool" or kind == "bool_auto":
        if value is True or value is False or (kind == "bool_auto" and value == "auto"):
            return value
        raise ValueError("%s must be true or false%s" % (key, " or auto" if kind == "bool_auto" else ""))
    if kind == "pin":
        if isinstance(value, (int, str)) and not isinstance(value, bool):
            return value
        raise ValueError("%s must be a pin number or name" % key)
    if kind.startswith("choice:"):
        options = kind[7:].split("|")
        if value in options:
            return value
        raise ValueError("%s must be one of %s" % (key, ", ".join(options)))
    if kind == "opt_float" and value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError("%s must be a number" % key)
    # before any int() or float(): int(inf) and float(10**400) raise OverflowError, not
    # ValueError; a number outside every range here is refused as what it is
    if not (-1e15 < value < 1e15):   # also NaN
        raise ValueError("%s=%s out of range %r..%r" % (key, "nan" if value != value else
                                                        ("huge" if value > 0 else "-huge"), lo, hi))
    if kind == "int":
        if value != int(value):
            raise ValueError("%s must be an integer" % key)
        value = int(value)
    else:
        value = float(value)
    if not (lo <= value <= hi):  # also rejects NaN
        raise ValueError("%s=%r out of range %r..%r" % (key, value, lo, hi))
    return value


def defaults():
    d = {}
    for k in SCHEMA:
        d[k] = SCHEMA[k][0]
    return d


def cross_check(cfg):
    """Relations between keys; ValueError on the first that fails."""
    if cfg["window"] > cfg["decim"]:
        raise ValueError("window (%d) must not exceed decim (%d)" % (cfg["window"], cfg["decim"]))
    from ads1292 import rate_code, gain_code
    rate_code(cfg["rate"])
    for k in ("gain_x", "gain_y", "gain_z"):
        gain_code(cfg[k])


def from_dict(d):
    """Defaults overlaid with the valid entries of d; returns (cfg, [problems])."""
    cfg = defaults()
    problems = []
    if not isinstance(d, dict):
        return cfg, ["config is not an object"]
    for k in d:
        try:
            cfg[k] = check(k, d[k])
        except ValueError as e:
            problems.append(str(e))
    try:
        cross_check(cfg)
    except ValueError as e:
        problems.append(str(e))
        for k in ("rate", "decim", "window", "gain_x", "gain_y", "gain_z"):
            cfg[k] = SCHEMA[k][0]
    return cfg, problems


def changed(cfg):
    """Only the keys that differ from the defaults (what config.json stores)."""
    out = {}
    for k in cfg:
        if cfg[k] != SCHEMA[k][0]:
            out[k] = cfg[k]
    return out
