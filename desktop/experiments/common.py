"""Shared steps of the experiments: simulate, smooth, fit, score, write tables and plots."""

import os

import numpy as np

from desktop.formats.capture import field_nT
from desktop.sim.scenario import Scenario, simulate

METHOD_LABELS = {"algebraic": "geometric (algebraic ellipsoid fit)", "paper-nn": "paper's neural network",
                 "streaming": "this project (shared/ streaming fit)", "mle": "maximum likelihood"}


def moving_average(h, rate, window_s=0.1, hop_s=0.01):
    """Boxcar means of `window_s` every `hop_s` (the paper's 0.1 s moving average), (M, 3)."""
    k = max(int(round(window_s * rate)), 1)
    hop = max(int(round(hop_s * rate)), 1)
    c = np.concatenate([np.zeros((1, h.shape[1])), np.cumsum(h, axis=0)])
    starts = np.arange(0, len(h) - k + 1, hop)
    return (c[starts + k] - c[starts]) / k


def capture_nT(truth=False, **scenario):
    """Simulate; return raw readings (N, 3) nT and the capture (with the truth if asked)."""
    cap = simulate(Scenario(**scenario), truth=truth)
    return field_nT(cap), cap


def thin(h, max_samples=40_000):
    """Every k-th sample so at most max_samples remain (no averaging: no smearing)."""
    return h[:: max(1, -(-len(h) // max_samples))]


def fit(h, method, field=None):
    from desktop.methods import fit_array
    return fit_array(h, method=method, field=field)


def score(cal, h, rate=None, window_s=0.1, vector=False):
    """(PTP, variance) of calibrated |h_c| (nT, nT^2); cal None: uncalibrated |h|.

    With `rate`, a `window_s` moving average is applied first: to the magnitude
    (rotation-invariant, no smearing) or, vector=True, to the raw vectors
    before calibration (smears while the sensor turns).
    """
    from desktop.methods import magnitudes
    if rate and vector:
        h = moving_average(h, rate, window_s)
    m = np.linalg.norm(h, axis=1) if cal is None else magnitudes(cal, h)
    if rate and not vector:
        m = moving_average(m[:, None], rate, window_s)[:, 0]
    return float(np.ptp(m)), float(np.var(m))


def paper_coverage(directions, cell_rad=0.01):
    """The paper's coverage (section IV.D): share of the sphere's area in (theta, phi)
    cells of cell_rad x cell_rad (area ~1e-4 on the unit sphere) holding a sample."""
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    theta = np.arctan2(d[:, 1], d[:, 0]) + np.pi
    phi = np.arccos(np.clip(d[:, 2], -1, 1))
    nt, nphi = int(np.ceil(2 * np.pi / cell_rad)), int(np.ceil(np.pi / cell_rad))
    it = np.minimum((theta / cell_rad).astype(int), nt - 1)
    ip = np.minimum((phi / cell_rad).astype(int), nphi - 1)
    hit = np.zeros((nt, nphi), bool)
    hit[it, ip] = True
    edges = np.minimum(np.arange(nphi + 1) * cell_rad, np.pi)
    area = (np.cos(edges[:-1]) - np.cos(edges[1:])) * cell_rad          # per cell, unit sphere
    return float((hit * area).sum() / (4 * np.pi))


def project_coverage(directions, cells_per_edge=8):
    """This project's coverage: share of shared.coverage's equal-area cells holding a sample."""
    from shared.coverage import Coverage
    cov = Coverage(cells_per_edge=cells_per_edge)
    for x, y, z in np.asarray(directions, float).tolist():
        cov.add(x, y, z)
    return cov.fraction()


def write_table(path, title, header, rows, notes=""):
    """A markdown table (rows of already formatted cells) with a title and notes."""
    lines = ["## " + title, "", "| " + " | ".join(header) + " |",
             "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    text = "\n".join(lines) + "\n" + ("\n" + notes.strip() + "\n" if notes else "")
    with open(path, "w") as fh:
        fh.write(text)
    return text


def figure():
    """matplotlib.pyplot on the Agg backend (`fluxcal experiment` checks it is installed)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def out_path(directory, name):
    os.makedirs(directory, exist_ok=True)
    return os.path.join(directory, name)
