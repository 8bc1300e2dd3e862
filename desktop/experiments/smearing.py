"""Smearing: the bias in |B| from averaging a turning vector, vs rotation rate and window.

A field vector turning at omega, averaged over a window T, is shorter by the
factor sin(theta/2)/(theta/2), theta = omega T (about B theta^2 / 24 for small
theta): at 1 rev/s a 0.1 s window loses 1.6 %, ~770 nT. Part 1 compares that
formula with the simulator (ideal sensor, constant-rate spin, 4000 SPS, boxcar
of the conversions). Part 2 calibrates from 2 minutes of hand rotation with
the firmware's options (boxcar window, rotation-rate gate on the change of
direction between consecutive windows) and scores a held-out hand rotation
(|h_c| of every conversion, then a 0.1 s moving average of the magnitude).
"""

import numpy as np

from desktop.experiments.common import capture_nT, figure, fit, out_path, score, thin, write_table
from desktop.sim.field import EARTH_NT

RATES_REV_S = (0.25, 0.5, 1.0, 2.0, 3.0)
WINDOWS_MS = (1.0, 2.5, 5.0, 10.0, 25.0, 100.0)
SPS = 4000


def analytic_bias(field, rev_s, window_s):
    theta = 2 * np.pi * rev_s * window_s
    return field * (1 - np.sinc(theta / (2 * np.pi)))       # np.sinc(x) = sin(pi x)/(pi x)


def simulated_bias(rev_s, window_s):
    h, _ = capture_nT(motion="spin", rot_rate=rev_s, seconds=1.0, rate=SPS, ideal=True, noise=0.0,
                      adc_noise=False, inclination_deg=0.0)
    k = max(int(round(window_s * SPS)), 1)
    means = h[: len(h) // k * k].reshape(-1, k, 3).mean(axis=1)
    return EARTH_NT - float(np.linalg.norm(means, axis=1).mean())


def windowed(h, k, gate_rev_s=None):
    """Boxcar means of k conversions (hop k), optionally gated on rotation rate."""
    m = h[: len(h) // k * k].reshape(-1, k, 3).mean(axis=1)
    if gate_rev_s is None:
        return m
    u = m / np.linalg.norm(m, axis=1, keepdims=True)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", u[1:], u[:-1]), -1, 1))
    worst = np.concatenate([ang[:1], np.maximum(ang[1:], ang[:-1]), ang[-1:]])  # either neighbour
    rate = worst / (k / SPS) / (2 * np.pi)
    return m[rate <= gate_rev_s]


def run(out):
    rows1, grid_a, grid_s = [], {}, {}
    for rev in RATES_REV_S:
        cells = [("%.2f" % rev)]
        for w in WINDOWS_MS:
            a, s = analytic_bias(EARTH_NT, rev, w / 1000), simulated_bias(rev, w / 1000)
            grid_a[(rev, w)], grid_s[(rev, w)] = a, s
            cells.append("%.2f (%.2f)" % (s, a))
        rows1.append(cells)
    t1 = write_table(out_path(out, "smearing.md"),
                     "Smearing bias of |B| (nT): simulated (analytic) at %s nT" % format(EARTH_NT, ",.0f"),
                     ["rev/s \\ window"] + ["%g ms" % w for w in WINDOWS_MS], rows1)
    cal, _ = capture_nT(sensor="mag649", rate=SPS, seed=0, motion_seed=1, seconds=120.0)
    test, _ = capture_nT(sensor="mag649", rate=SPS, seed=0, motion_seed=2, seconds=30.0)
    rows2 = []
    for w in (0.25, 2.5, 5.0, 10.0, 25.0, 100.0):
        k = max(int(round(w / 1000 * SPS)), 1)
        for gate in (None, 1.0, 0.5):
            sel = windowed(cal, k, gate)
            if len(sel) < 100:
                continue
            ptp, var = score(fit(thin(sel), "streaming"), test, SPS)
            rows2.append(["%g" % w, "-" if gate is None else "%.1f" % gate, "%d" % len(sel),
                          "%.2f" % ptp, "%.3f" % var])
    t2 = write_table(out_path(out, "smearing_calibration.md"),
                     "Calibration from windowed hand data (Mag649, 4000 SPS, streaming fit; held-out scoring)",
                     ["window (ms)", "rate gate (rev/s)", "samples", "PTP (nT)", "Var (nT^2)"], rows2)
    plt = figure()
    fig, ax = plt.subplots(figsize=(6, 4))
    for rev in RATES_REV_S:
        ax.loglog(WINDOWS_MS, [grid_a[(rev, w)] for w in WINDOWS_MS], "-", lw=0.8)
        ax.loglog(WINDOWS_MS, [max(grid_s[(rev, w)], 1e-3) for w in WINDOWS_MS], "o",
                  label="%.2f rev/s" % rev)
    ax.axhline(0.5, color="grey", lw=0.5)
    ax.set_xlabel("averaging window (ms)")
    ax.set_ylabel("|B| bias (nT): dots simulated, lines sin(t/2)/(t/2)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out_path(out, "smearing.png"), dpi=110)
    return t1 + "\n" + t2
