"""A first synthetic data generator: a distorted three-axis sensor in a uniform field.

The sensor model is the paper's (section II.B, Fig. 1): the sensing axes W1, W2,
W3 are not orthogonal (angles v12, v13, v23 away from 90 degrees), each axis has
its own gain and offset, and white noise is added per axis:

    h_r = S T h + o + n                                            (1)

T's rows are the unit axis directions in an orthogonal frame (W1 = u1,
W2 in the u1-u2 plane, W3 general), S = diag(1 + s_i), o the offsets (nT),
n ~ N(0, sigma^2) per axis. The exact inverse, h = (S T)^-1 (h_r - o), gives
the noise floor. The full simulator (ADC, hand, bandwidth) is desktop.sim.

Direction sets (unit vectors in the sensor frame, (N, 3)): ``uniform``,
``cap`` (a spherical cap holding a given fraction of the sphere's area) and
``tumble`` (a smooth random hand rotation).
"""

import numpy as np


class Sensor:
    """A distorted vector magnetometer, eq. (1).

    Parameters
    ----------
    nonorthogonality_deg : (3,) angles v12, v13, v23 in degrees
    scale_error : (3,) relative gain errors s_i
    offset : (3,) offsets o in nT
    noise : white noise sigma per axis, nT rms
    """

    def __init__(self, nonorthogonality_deg=(0.0, 0.0, 0.0), scale_error=(0.0, 0.0, 0.0),
                 offset=(0.0, 0.0, 0.0), noise=0.0):
        v12, v13, v23 = np.radians(np.asarray(nonorthogonality_deg, dtype=float))
        w1 = np.array([1.0, 0.0, 0.0])
        w2 = np.array([np.sin(v12), np.cos(v12), 0.0])
        # W3 makes angle 90-v13 with u1 and 90-v23 with u2 (small-angle exact form).
        w3x = np.sin(v13)
        w3y = (np.sin(v23) - w2[0] * w3x) / w2[1]
        w3 = np.array([w3x, w3y, np.sqrt(max(0.0, 1.0 - w3x**2 - w3y**2))])
        self.axes = np.vstack([w1, w2, w3])
        self.gain = np.diag(1.0 + np.asarray(scale_error, dtype=float))
        self.distortion = self.gain @ self.axes
        self.offset = np.asarray(offset, dtype=float)
        self.noise = float(noise)

    @classmethod
    def random(cls, rng, nonorthogonality_deg=1.0, scale_error=0.005, offset=10.0, noise=0.1):
        """A sensor with errors drawn uniformly within the given bounds (the paper's typical values)."""
        return cls(
            rng.uniform(-nonorthogonality_deg, nonorthogonality_deg, 3),
            rng.uniform(-scale_error, scale_error, 3),
            rng.uniform(-offset, offset, 3),
            noise,
        )

    def measure(self, field, rng=None):
        """Raw readings (N, 3) nT for true field vectors `field` (N, 3) nT in the sensor frame."""
        raw = field @ self.distortion.T + self.offset
        if self.noise > 0:
            raw = raw + rng.normal(0.0, self.noise, raw.shape)
        return raw

    def true_correction(self):
        """(matrix, offset) of the exact inverse: h = matrix (h_r - offset)."""
        return np.linalg.inv(self.distortion), self.offset.copy()


def uniform_directions(rng, n):
    """(n, 3) unit vectors uniform on the sphere."""
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def cap_directions(rng, n, fraction, axis=None):
    """(n, 3) unit vectors uniform on a cap holding `fraction` of the sphere's area.

    A cap of half-angle theta has area fraction (1 - cos theta) / 2, so
    cos theta = 1 - 2 fraction; uniform on the cap means cos uniform in [cos theta, 1].
    """
    if not 0 < fraction <= 1:
        raise ValueError("fraction must be in (0, 1], got %r" % fraction)
    c = rng.uniform(1.0 - 2.0 * fraction, 1.0, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    s = np.sqrt(1.0 - c**2)
    local = np.column_stack([s * np.cos(phi), s * np.sin(phi), c])
    if axis is None:
        axis = uniform_directions(rng, 1)[0]
    return local @ _frame(np.asarray(axis, dtype=float)).T


def _frame(z):
    """A rotation matrix whose third column is the unit vector z."""
    z = z / np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


def tumble_directions(rng, n, rate_hz=100.0, rev_per_s=1.0, field_dir=(0.0, 0.0, 1.0)):
    """(n, 3) field directions in the frame of a sensor tumbled by hand.

    The angular velocity is a smooth random process (Ornstein-Uhlenbeck with a
    0.5 s correlation time) of rms rate 2 pi rev_per_s rad/s; the orientation is
    integrated from it with exact rotation steps (Rodrigues), so the directions
    wander over the sphere the way a hand's do, unevenly.
    """
    dt = 1.0 / rate_hz
    tau = 0.5
    sigma = 2.0 * np.pi * rev_per_s / np.sqrt(3.0)
    a = np.exp(-dt / tau)
    kicks = rng.normal(0.0, sigma * np.sqrt(1.0 - a * a), (n, 3))
    omega = np.empty((n, 3))
    w = rng.normal(0.0, sigma, 3)
    for k in range(n):  # O(n) recursion; n is at most a few 10^5 here
        w = a * w + kicks[k]
        omega[k] = w
    field = np.asarray(field_dir, dtype=float)
    field = field / np.linalg.norm(field)
    out = np.empty((n, 3))
    r = np.eye(3)
    for k in range(n):
        out[k] = r.T @ field  # the field seen in the sensor frame
        r = r @ _rotation(omega[k] * dt)
    return out


def _rotation(phi):
    angle = np.linalg.norm(phi)
    if angle < 1e-15:
        return np.eye(3)
    k = phi / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * kx + (1.0 - np.cos(angle)) * (kx @ kx)


def directions(kind, rng, n, coverage=1.0):
    """Direction set by name: 'uniform', 'cap' (with coverage) or 'tumble'."""
    if kind == "uniform":
        return uniform_directions(rng, n)
    if kind == "cap":
        return cap_directions(rng, n, coverage)
    if kind == "tumble":
        return tumble_directions(rng, n)
    raise ValueError("unknown direction set %r" % kind)
