"""The paper's field procedure, scripted: boot, press, rotate by hand, auto-finish, verify with a spin.

    r = calibrate_and_verify(kind="micropython", root=tmpdir, rotate_s=60)
    r["cal"]          # the firmware's final "cal" event (state done/failed, reason, rms, ...)
    r["ptp_cal"]      # PTP of the firmware's calibrated |B| over a 360 degree spin, nT
    r["ptp_raw"]      # the same spin through the nominal front-end scale only, nT

Everything measured here is what the firmware printed on its serial line
(JSON events), nothing is recomputed from the simulator's truth except the
uncalibrated |B|, which applies the configured nT/code to the raw codes the
firmware streams beside its corrected values.
"""

import json
import os

import numpy as np

from desktop.devicesim.costs import COSTS_S
from desktop.devicesim.runners import start_device, write_config
from desktop.devicesim.world import make_world
from desktop.firmware.files import import_device
from shared import codes

_ENDED = (codes.DONE, codes.FAILED, codes.CANCELLED)   # a session's last `cal` event


def handheld_config(scenario, kind="cpython"):
    """The config.json keys that describe the simulated handheld (what a user sets once for
    their board): the front end's scale_x/y/z, from its nominal nT per code, the sensor's
    bandwidth (the rate gate follows it), and, for a
    CircuitPython board, the pins by their board names (its HAL looks them up in `board`;
    the wiring is config.py's defaults, GPIO numbers)."""
    from desktop.sim.sensor import PRESETS
    k = scenario.nt_per_code()
    bw = scenario.bandwidth if scenario.bandwidth != "preset" else PRESETS[scenario.sensor]["bandwidth_hz"]
    cfg = {"scale_x": float(k[0]), "scale_y": float(k[1]), "scale_z": float(k[2]),
           "sensor_bandwidth_hz": float(bw or 100000.0)}
    if kind.startswith("board:circuitpython"):
        schema = import_device("config").SCHEMA
        cfg.update({key: "GP%d" % spec[0] for key, spec in schema.items() if spec[1] == "pin"})
    return cfg


def events(world, name=None, since=0):
    out = []
    for line in world.lines()[since:]:
        try:
            d = json.loads(line)
        except ValueError:
            continue
        if name is None or d.get("ev") == name:
            out.append(d)
    return out


def _progress(lines):
    """Progress events with the seconds since the first one (events come once per second)."""
    out = []
    for d in _parse(lines):
        if d.get("ev") == codes.EV_CAL and d.get("state") == codes.COLLECTING:
            d["t_s"] = float(len(out))
            out.append(d)
    return out


def _parse(lines):
    for line in lines:
        try:
            yield json.loads(line)
        except ValueError:
            continue


def send(dev, world, line, dt=0.05):
    """Type a command on the (in-memory or pty) serial line and let the device answer."""
    world.send((line + "\n").encode())
    dev.run_until(world.time + dt)


def calibrate_and_verify(kind="micropython", root="out/device", seed=1, rotate_s=120.0, spin_s=10.0,
                         noise_nt=0.1, rate=1000, progress=None, motion_seed=11, cal_world=None, polled=False,
                         costs=COSTS_S, on_cal_device=None, sensor=None, rot_rate=1.0, spin_rev_s=None,
                         **config):
    """Calibrate on one simulated capture (hand), verify on another (spin), same sensor.

    Like the real procedure: the firmware boots, the operator presses the
    button and rotates until the LED says done (auto-finish) or rotate_s
    passes (then presses again); later the instrument is switched on again
    (the calibration comes back from flash) and turned once about the vertical.
    The sensor, front end and motions are the simulator's (desktop/sim/handheld.py).
    cal_world: extra desktop.sim.scenario.Scenario settings for the calibration
    capture only (e.g. a passing dipole); the verification spin stays clean.
    polled, costs: the simulated board's DRDY mode and main-loop cost model
    (hal_sim.Board; costs.COSTS_S by default). on_cal_device(dev, world) runs
    right after the calibration run's boot (e.g. to install spies in-process).
    sensor: Scenario settings of the sensor for both captures (e.g. {"sensor": "mag648"});
    rot_rate: the hand's pace (rev/s); spin_rev_s: the spin's rate (default one turn in spin_s).
    """
    sensor = sensor or {}
    os.makedirs(root, exist_ok=True)
    w = make_world(serial=None, motion="hand", seconds=rotate_s + 3.0, seed=seed, rot_rate=rot_rate,
                   motion_seed=motion_seed, noise=noise_nt, rate=rate, **dict(sensor, **(cal_world or {})))
    scale = w.scenario.nt_per_code()
    write_config(root, **dict(handheld_config(w.scenario, kind), rate=rate, **config))
    # a board's own HAL decides polling, and charges no costs (its busy() is hardware's no-op)
    options = {} if kind.startswith("board:") else {"polled": polled, "costs": costs}
    if on_cal_device is not None:
        options["on_boot"] = lambda dev: on_cal_device(dev, w)
    dev = start_device(w, root, kind=kind, **options)
    try:
        dev.run_until(0.5)
        w.press(0.2)
        t_press = w.time
        done = None
        n0 = 0
        t = t_press
        while t < t_press + rotate_s and done is None:
            t = min(t + 1.0, t_press + rotate_s)
            dev.run_until(t)
            for e in events(w, codes.EV_CAL, n0):
                if e.get("state") in _ENDED:
                    done = e
            n0 = len(w.lines())
            if progress:
                progress(w.time - t_press, events(w, codes.EV_CAL)[-1:])
        rotated = w.time - t_press
        if done is None:   # no auto-finish: the operator presses again
            w.press(0.2)
            dev.run_until(w.time + 0.5)
            for e in events(w, codes.EV_CAL, n0):
                if e.get("state") in _ENDED:
                    done = e
        send(dev, w, "get-coverage")
        cov = events(w)[-1]
        send(dev, w, "status")
        cal_status = events(w)[-1]
        collecting = [e for e in events(w, codes.EV_CAL) if e.get("state") == codes.COLLECTING]
        cal_lines = w.lines()
    finally:
        dev.close()
    # verification: power on again, one 360 degree turn about the vertical in spin_s
    w2 = make_world(serial=None, motion="spin", seconds=spin_s + 2.0, rot_rate=spin_rev_s or 1.0 / spin_s,
                    seed=seed, motion_seed=motion_seed + 1, noise=noise_nt, rate=rate, **sensor)
    options.pop("on_boot", None)
    dev = start_device(w2, root, kind=kind, **options)
    try:
        dev.run_until(0.3)
        boot = events(w2, "boot")
        send(dev, w2, "stream corrected")
        n0 = len(w2.lines())
        t0 = w2.time
        dev.run_until(t0 + spin_s)
        spin = events(w2, "data", n0)
        send(dev, w2, "stream off")
        send(dev, w2, "status")
        status = events(w2)[-1]
    finally:
        dev.close()
    f_cal = np.array([d["f"] for d in spin])
    c = np.array([d["c"] for d in spin])
    f_raw = np.linalg.norm(c * scale, axis=1) if len(c) else np.array([])
    return {
        "kind": kind,
        "cal": done,
        "boot": boot[0] if boot else None,
        "rotated_s": rotated,
        "spin_f_cal": f_cal,
        "spin_f_raw": f_raw,
        "ptp_cal": float(np.ptp(f_cal)) if len(f_cal) else None,
        "var_cal": float(np.var(f_cal)) if len(f_cal) else None,
        "ptp_raw": float(np.ptp(f_raw)) if len(f_raw) else None,
        "var_raw": float(np.var(f_raw)) if len(f_raw) else None,
        "status": status,
        "cal_status": cal_status,
        "cal_lines": cal_lines,
        "coverage": cov if cov.get("ok") else None,
        "last_progress": collecting[-1] if collecting else None,
        "ready_at_s": next((e["t_s"] for e in _progress(cal_lines) if e.get("ready")), None),
        "lines": w2.lines(),
        "world": w,
    }
