"""The scripted field calibration: boot, press, rotate by hand, auto-finish, verify with a spin.

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

from desktop.devicesim.physics import NT_PER_CODE
from desktop.devicesim.runner import make_world, start_device


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


def send(dev, world, line, dt=0.05):
    """Type a command on the (in-memory or pty) serial line and let the device answer."""
    world.send((line + "\n").encode())
    dev.run_until(world.time + dt)


def calibrate_and_verify(kind="micropython", root="out/device", seed=1, rotate_s=120.0, spin_s=20.0,
                         noise_nt=0.1, rev_per_s=0.6, world=None, progress=None):
    os.makedirs(root, exist_ok=True)
    w = world or make_world(seed=seed, noise_nt=noise_nt, serial=None)
    m = w.analog.motion
    m.still(1.0)
    dev = start_device(w, root, kind=kind)
    try:
        dev.run_until(1.0)
        # the operator: one short press, then rotate until the LED says done (auto-finish)
        w.press(0.2)
        t_press = w.time
        t = t_press
        done = None
        n0 = len(w.lines())
        while t < t_press + rotate_s:
            t = min(t + 1.0, t_press + rotate_s)
            while m.duration < t + 2.0:  # script the hand ahead of the analog grid (0.5 s)
                m.hand(1.0, rev_per_s=rev_per_s)
            dev.run_until(t)
            for e in events(w, "cal", n0):
                if e.get("state") in ("done", "failed", "cancelled"):
                    done = e
            n0 = len(w.lines())
            if progress:
                progress(w.time - t_press)
            if done:
                break
        rotated = w.time - t_press
        if done is None:   # no auto-finish: the operator presses again
            w.press(0.2)
            dev.run_until(w.time + 0.5)
            for e in events(w, "cal"):
                if e.get("state") in ("done", "failed", "cancelled"):
                    done = e
        # verification: hold still, then one slow 360 degree spin about the vertical
        m.still(2.0)
        m.spin(spin_s, 360.0)
        m.still(2.0)
        send(dev, w, "stream corrected")
        t_spin = m.duration - 2.0 - spin_s
        dev.run_until(t_spin)
        n0 = len(w.lines())
        dev.run_until(t_spin + spin_s)
        spin = events(w, "data", n0)
        send(dev, w, "stream off")
        send(dev, w, "status")
        status = events(w)[-1]
    finally:
        dev.close()
    f_cal = np.array([d["f"] for d in spin])
    c = np.array([d["c"] for d in spin])
    f_raw = np.linalg.norm(c * NT_PER_CODE, axis=1)
    return {
        "kind": kind,
        "cal": done,
        "rotated_s": rotated,
        "spin_f_cal": f_cal,
        "spin_f_raw": f_raw,
        "ptp_cal": float(np.ptp(f_cal)) if len(f_cal) else None,
        "var_cal": float(np.var(f_cal)) if len(f_cal) else None,
        "ptp_raw": float(np.ptp(f_raw)) if len(f_raw) else None,
        "var_raw": float(np.var(f_raw)) if len(f_raw) else None,
        "status": status,
        "world": w,
        "lines": w.lines(),
    }
