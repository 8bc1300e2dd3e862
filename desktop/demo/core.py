"""The calibration core on a simulated hand calibration, beside the references.

A fluxgate with the paper's typical errors (1 degree, 0.5 %, offsets) is
rotated by hand for two minutes (100 samples/s after averaging), fitted by
the device's own code (shared.fit, double and float32) and by the numpy
references, then verified on a separate 360-degree spin of the same sensor.
"""

import time

import numpy as np

from desktop.methods import fit_array, magnitudes
from desktop.sim.field import EARTH_NT as FIELD
from desktop.sim.points import tumble_directions
from desktop.sim.sensor import Sensor
PAPER_TABLE2 = {"uncalibrated": (24055, 652), "geometric": (15, 3), "neural network": (8, 4)}


def spin_directions(n, tilt_deg=30.0):
    """A full turn about an axis tilted from the field: |B| errors show as the paper's Fig. 6."""
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    tilt = np.radians(tilt_deg)
    return np.column_stack([np.sin(tilt) * np.cos(t), np.sin(tilt) * np.sin(t), np.full(n, np.cos(tilt))]) @ _mix().T


def _mix():
    a = np.radians(35.0)
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def run_core_demo(seed=1, noise=0.1, seconds=120.0, rate=100.0):
    rng = np.random.default_rng(seed)
    sensor = Sensor.random(rng, 1.0, 0.005, 1000.0, noise)
    hand = sensor.measure(FIELD * tumble_directions(np.random.default_rng(seed + 1), int(seconds * rate), rate), rng)
    spin = sensor.measure(FIELD * spin_directions(3600), rng)
    print("Simulated hand calibration: %.0f s at %.0f samples/s, sensor noise %.2f nT, field %.0f nT" % (seconds, rate, noise, FIELD))
    print("Verification: a separate 360-degree spin (3600 samples). |B| statistics in nT.\n")
    rows = [("uncalibrated", np.linalg.norm(spin, axis=1), None)]
    m_true, b_true = sensor.true_correction()
    rows.append(("noise floor (true parameters)", np.linalg.norm((spin - b_true) @ m_true.T, axis=1), None))
    for label, method, kw in [
        ("streaming (shared/, double)", "streaming", {}),
        ("streaming (shared/, float32)", "streaming", {"float32": True}),
        ("algebraic (Li-Griffiths)", "algebraic", {}),
        ("geometric MLE", "mle", {}),
        ("paper NN (sec. III.B)", "paper-nn", {}),
    ]:
        t0 = time.perf_counter()
        cal = fit_array(hand, method, field=FIELD, **kw)
        rows.append((label, magnitudes(cal, spin), time.perf_counter() - t0))
    print("%-32s %12s %12s %9s" % ("method", "PTP (nT)", "var (nT^2)", "fit (s)"))
    for label, mag, dt in rows:
        print("%-32s %12.3f %12.4f %9s" % (label, np.ptp(mag), np.var(mag), "" if dt is None else "%.2f" % dt))
    print("\nPaper, Table 2 (real Mag649 data, 0.1 s moving average): uncalibrated 24,055 / 652; geometric 15 / 3; neural network 8 / 4")
    return 0
