"""The analog world the simulated handheld sees: Earth field, hand motion, fluxgate, front end.

Kept small on purpose: the ADS1292 itself is desktop.sim.ads1292 (byte-level
emulator); this module only turns a motion script into the (G, 2) input volts
of each chip on the emulator's 16 kHz grid.

Motion is a timeline of body-frame angular velocities sampled at 200 Hz and the
orientations integrated from them with exact rotation steps (Rodrigues);
between two knots the sensor turns at the knot's constant rate, so the field
seen on the fine grid is exact for that piecewise-constant rate.

Units: nT, seconds, volts; arrays (N, 3) are x, y, z in the sensor frame.
"""

import numpy as np

from desktop.synth import Sensor
from desktop.synth import _rotation as _rotmat   # exact rotation from a rotation vector (Rodrigues)

KNOT_HZ = 200
# Bartington Mag649: 0.1 V/uT (1e-4 V/nT), +-100 uT; a 4.5:1 divider keeps
# +-10 V inside the ADS1292's +-2.42 V at gain 1.
V_PER_NT = 1e-4 / 4.5
VREF = 2.42
NT_PER_CODE = (VREF / (2 ** 23 - 1)) / V_PER_NT   # 0.01298 nT/code at gain 1


def earth_field(total=48000.0, inclination_deg=62.0, declination_deg=3.0):
    """World-frame field (x north, y east, z down), nT."""
    i = np.radians(inclination_deg)
    d = np.radians(declination_deg)
    return total * np.array([np.cos(i) * np.cos(d), np.cos(i) * np.sin(d), np.sin(i)])


def _rotate(v, axis_angle):
    """Rotate rows of v by rotation vectors (rows of axis_angle), Rodrigues, vectorised."""
    ang = np.linalg.norm(axis_angle, axis=-1, keepdims=True)
    safe = np.where(ang > 1e-15, ang, 1.0)
    k = axis_angle / safe
    c = np.cos(ang)
    s = np.sin(ang)
    kv = np.sum(k * v, axis=-1, keepdims=True)
    return v * c + np.cross(k, v) * s + k * kv * (1.0 - c)


class Motion:
    """Orientation over time, built segment by segment (continuous across segments)."""

    def __init__(self, seed=0, start=None):
        self.rng = np.random.default_rng(seed)
        self.R = [np.eye(3) if start is None else np.asarray(start, float)]  # body -> world at knots
        self.w = []          # body-frame rate (rad/s) held from knot k to k+1
        self._ou = self.rng.normal(0.0, 1.0, 3)

    @property
    def duration(self):
        return len(self.w) / KNOT_HZ

    def _push(self, w_body):
        self.w.append(np.asarray(w_body, float))
        self.R.append(self.R[-1] @ _rotmat(self.w[-1] / KNOT_HZ))

    def still(self, seconds):
        for _ in range(int(round(seconds * KNOT_HZ))):
            self._push(np.zeros(3))
        return self

    def hand(self, seconds, rev_per_s=0.6, tau=0.5):
        """Tumbling by hand: Ornstein-Uhlenbeck body rate, rms 2 pi rev_per_s rad/s, tau s."""
        dt = 1.0 / KNOT_HZ
        a = np.exp(-dt / tau)
        sigma = 2.0 * np.pi * rev_per_s / np.sqrt(3.0)
        for _ in range(int(round(seconds * KNOT_HZ))):
            self._ou = a * self._ou + np.sqrt(1.0 - a * a) * self.rng.normal(0.0, 1.0, 3)
            self._push(sigma * self._ou)
        return self

    def spin(self, seconds, degrees=360.0, axis_world=(0.0, 0.0, 1.0)):
        """A single-axis turn about a world axis (the paper's Fig. 6 verification)."""
        n = int(round(seconds * KNOT_HZ))
        rate = np.radians(degrees) / seconds
        ax = np.asarray(axis_world, float)
        ax = ax / np.linalg.norm(ax)
        for _ in range(n):
            self._push(self.R[-1].T @ (rate * ax))
        return self

    def field_body(self, t, field_world):
        """Field in the sensor frame at times t (G,), nT (G, 3); held still past the end.

        field_world: (3,) or (G, 3) world-frame field, nT.
        """
        t = np.asarray(t, float)
        k = np.clip(np.floor(t * KNOT_HZ).astype(int), 0, len(self.w))
        R = np.asarray(self.R)
        W = np.asarray(self.w + [np.zeros(3)])
        tau = np.clip(t - k / KNOT_HZ, 0.0, None)
        tau = np.where(k >= len(self.w), 0.0, tau)
        F = np.broadcast_to(np.asarray(field_world, float), (len(t), 3))
        v = np.einsum("kji,kj->ki", R[k], F)                 # R_k^T F
        return _rotate(v, -W[k] * tau[:, None])              # Rot(w tau)^T R_k^T F


class Analog:
    """Field -> fluxgate (desktop.synth.Sensor) -> front end volts for the two chips."""

    def __init__(self, motion, sensor=None, field_world=None, noise_nt=0.1, seed=0,
                 temperature_c=25.0, disturbances=(), grid_hz=16000, data_rate=2000):
        self.motion = motion
        self.rng = np.random.default_rng(seed)
        self.sensor = sensor if sensor is not None else Sensor.random(np.random.default_rng(seed + 1000),
                                                                      noise=0.0)
        self.field_world = earth_field() if field_world is None else np.asarray(field_world, float)
        self.noise = noise_nt
        # noise_nt is the rms per ADC output sample; the ADC's sinc3 averages
        # about grid_hz/data_rate grid samples, so the grid carries more.
        self.noise_grid = noise_nt * np.sqrt(grid_hz / data_rate)
        self.temperature_c = temperature_c
        self.disturbances = list(disturbances)  # (t_center, width_s, world-frame peak vector nT)

    def raw_nt(self, t):
        """Sensor output (G, 3) nT at times t, noise included."""
        f = np.broadcast_to(self.field_world, (len(t), 3)).copy()
        for tc, width, peak in self.disturbances:
            f += np.exp(-0.5 * ((t - tc) / width) ** 2)[:, None] * np.asarray(peak, float)
        raw = self.sensor.measure(self.motion.field_body(t, f))
        if self.noise > 0:
            raw = raw + self.rng.normal(0.0, self.noise_grid, raw.shape)
        return raw

    def volts(self, t):
        """((G, 2) chip 0: x, y), ((G, 2) chip 1: z, unused) in volts."""
        raw = self.raw_nt(t) * V_PER_NT
        z = np.zeros(len(t))
        return raw[:, :2].copy(), np.column_stack([raw[:, 2], z])
