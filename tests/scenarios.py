"""Seeded test scenarios shared by the core tests (numpy side)."""

import numpy as np

from desktop.methods import quantise
from desktop.sim.field import EARTH_NT as FIELD
from desktop.sim.points import directions
from desktop.sim.sensor import Sensor

LSB = 1e-3


def scenario(seed, kind="uniform", coverage=1.0, n=3000, noise=0.1, offset=1000.0, nonorth=1.0, scale=0.005):
    """(raw quantised nT (N,3), sensor, held-out full-sphere clean raw (M,3))."""
    rng = np.random.default_rng(seed)
    sensor = Sensor.random(rng, nonorth, scale, offset, noise)
    raw = sensor.measure(FIELD * directions(kind, rng, n, coverage), rng)
    raw = np.array(quantise(raw, LSB)) * LSB  # what the integer core sees
    sphere = FIELD * directions("uniform", rng, 4000) @ sensor.distortion.T + sensor.offset
    return raw, sensor, sphere
