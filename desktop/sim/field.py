"""The magnetic field at the sensor: Earth field, drift, gradient, a passing dipole.

World frame: x north, y east, z down (the usual geomagnetic NED convention).
"""

import numpy as np

MU0_4PI_NT = 100.0          # mu0 / 4 pi = 1e-7 T m/A = 100 nT m^3 / (A m^2)
# The simulated site, used by every part of the simulation that needs a field:
# mid-latitude Europe (IGRF gives 47-49 uT, inclination 60-65 deg there).
EARTH_NT = 47_000.0
INCLINATION_DEG = 62.0
DECLINATION_DEG = 3.0


def earth_vector(magnitude_nT=EARTH_NT, inclination_deg=INCLINATION_DEG, declination_deg=DECLINATION_DEG):
    """Earth field vector (3,) in nT, NED, from magnitude, inclination (down
    from horizontal) and declination (east of north). Defaults: the simulated site."""
    i, d = np.radians(inclination_deg), np.radians(declination_deg)
    return magnitude_nT * np.array([np.cos(i) * np.cos(d), np.cos(i) * np.sin(d), np.sin(i)])


class Field:
    """B(t, position) in the world frame, nT.

    Parameters
    ----------
    earth : (3,) array, nT
        Uniform background field.
    drift_nT_per_min : float
        Slow drift along the background direction (diurnal variation is tens of
        nT over hours; a few nT/min on an active day), linear in time.
    gradient_nT_per_m : float
        A vertical gradient of the background: dB/dz = g along B's direction,
        as a symmetric traceless tensor (curl- and divergence-free).
    dipole : dict or None
        A passing magnetic dipole (a vehicle): keys moment_Am2 (3,), distance_m
        (closest approach), speed_m_s, t_closest_s. It moves along world x at
        height 0, passing at `distance_m` to the east of the sensor.
    """

    def __init__(self, earth=None, drift_nT_per_min=0.0, gradient_nT_per_m=0.0, dipole=None):
        self.earth = earth_vector() if earth is None else np.asarray(earth, dtype=float)
        self.direction = self.earth / np.linalg.norm(self.earth)
        self.drift = drift_nT_per_min / 60.0
        z = np.array([0.0, 0.0, 1.0])
        g = np.outer(self.direction, z)
        g = 0.5 * (g + g.T)
        self.gradient = gradient_nT_per_m * (g - np.trace(g) / 3.0 * np.eye(3))
        self.dipole = dipole
        self.steps = []             # (t s, nT): from t on, B is larger by nT along its direction

    def add_step(self, t, nT):
        """From time t on, the background is `nT` larger (a live world's field step)."""
        self.steps.append((float(t), float(nT)))

    @property
    def uniform(self):
        """True when B is the same everywhere and always (no drift, gradient, dipole, steps)."""
        return not (self.drift or self.gradient.any() or self.dipole or self.steps)

    def at(self, t, position):
        """Field vectors (N, 3) nT at times t (N,) s and positions (N, 3) m."""
        b = np.broadcast_to(self.earth, position.shape).copy()
        if self.drift:
            b += np.outer(self.drift * np.asarray(t), self.direction)
        if self.gradient.any():
            b += position @ self.gradient.T
        if self.dipole:
            b += self.dipole_field(t, position)
        for t0, nT in self.steps:
            b += np.outer(nT * (np.asarray(t) >= t0), self.direction)
        return b

    def dipole_field(self, t, position):
        """Field (N, 3) nT of the passing dipole: mu0/4pi (3 (m.r^) r^ - m) / r^3."""
        d = self.dipole
        m = np.asarray(d.get("moment_Am2", (0.0, 0.0, 300.0)), dtype=float)
        src = np.zeros((len(t), 3))
        src[:, 0] = d.get("speed_m_s", 10.0) * (np.asarray(t) - d.get("t_closest_s", 30.0))
        src[:, 1] = d.get("distance_m", 20.0)
        r = position - src
        rn = np.linalg.norm(r, axis=1, keepdims=True)
        rh = r / rn
        return MU0_4PI_NT * (3 * (rh @ m)[:, None] * rh - m) / rn ** 3
