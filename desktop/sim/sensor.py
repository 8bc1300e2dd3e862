"""The fluxgate and its analog front end: field (nT) in, ADC input volts out.

Sensor model (the paper's, section II.B and Fig. 1): non-orthogonal sensing
axes W1, W2, W3 (angles v12, v13, v23 away from 90 degrees), per-axis scale
errors and offsets:

    r = S T b (1 + k_s dT) + o + k_o dT                               (1)

T's rows are the unit axis directions (W1 = u1, W2 in the u1-u2 plane), S =
diag(1 + s_i), o offsets (nT), k_s / k_o temperature coefficients of scale
(ppm/C) and offset (nT/C), dT the temperature change since the calibration
reference (25 C). Each axis then passes a low-pass at the sensor bandwidth
(first order; or two equal real poles with the same -3 dB bandwidth, ``poles``: 2),
optionally with per-axis bandwidths drawn within +-``bandwidth_spread``, white noise is added (nT rms per ADC conversion, see
:meth:`Fluxgate.noise_grid_rms`), optional 1/f noise, and the output voltage
(sensitivity V/nT) is attenuated by the front end (per-axis divider with its
tolerance, plus an offset in volts) onto the ADS1292 input range.

:class:`Sensor` is eq. (1) alone (DC, 25 C, white noise): what the point
samples of desktop/sim/points.py measure. :class:`Fluxgate` adds the
temperature terms, the bandwidth and the front end, for a capture in time.

Presets (:data:`PRESETS`) hold the paper's two sensors, Bartington Mag648
(5 Hz bandwidth) and Mag649 (1 kHz); the errors are the paper's "typical values"
(non-orthogonality < 1 degree, offset < 10 nT, scale < 0.5 %). ``paper`` is a Mag649
whose uncalibrated spin is as far from a sphere as the paper's in-situ recording (Table 2:
24,055 nT PTP; the paper gives no breakdown of its errors): gains within 34 % (its
channels' unmatched scales), offsets within 5,000 nT, axes within 2 degrees. The +-10 V for
+-100 uT output (100 uV/nT) and the front-end figures are this project's
assumptions, stated in docs/simulator.md.
"""

import numpy as np

from desktop.sim.filters import alpha, lowpass

# Two equal real poles with -3 dB at f_c: each pole at f_c / sqrt(sqrt(2) - 1)
TWO_POLE_FACTOR = 1.0 / np.sqrt(np.sqrt(2.0) - 1.0)
PRESETS = {
    "mag649": {"bandwidth_hz": 1000.0},
    "mag648": {"bandwidth_hz": 5.0},
    # gain bound chosen so that seed 0's 0.5 rev/s spin reads Table 2's 24,055 nT PTP (tests/test_sim_response.py)
    "paper": {"bandwidth_hz": 1000.0, "offset_nT": 5000.0, "scale_error": 0.344,
              "nonorthogonality_deg": 2.0},
}
COMMON = {
    "sensitivity_V_per_nT": 1e-4,      # +-10 V for +-100 uT
    "nonorthogonality_deg": 1.0,       # bound of each angle (uniform draw)
    "scale_error": 0.005,              # bound of each relative gain error
    "offset_nT": 10.0,                 # bound of each offset
    "noise_nT": 0.1,                   # white, rms per conversion
    "pink_nT": 0.0,                    # 1/f component, rms over 0.01..10 Hz
    "tempco_offset_nT_per_C": 0.1,     # bound, per axis
    "tempco_scale_ppm_per_C": 20.0,    # bound, per axis
    "attenuation": 0.2,                # front end: +-10 V onto +-2 V
    "attenuation_tolerance": 0.02,     # 1 % resistors, two per divider
    "frontend_offset_V": 2e-3,         # bound of the front-end offset per axis
    "poles": 1,                        # 1: first-order response; 2: two equal poles (same -3 dB)
    "bandwidth_spread": 0.0,           # bound of each axis' relative bandwidth error
}


def axes_matrix(v12, v13, v23):
    """Rows: unit sensing axes W1, W2, W3 for non-orthogonality angles (rad), Fig. 1."""
    w2 = np.array([np.sin(v12), np.cos(v12), 0.0])
    w3x = np.sin(v13)
    w3y = (np.sin(v23) - w2[0] * w3x) / w2[1]     # W3 . W2 = sin v23
    return np.array([[1.0, 0.0, 0.0], w2, [w3x, w3y, np.sqrt(1.0 - w3x ** 2 - w3y ** 2)]])


class Sensor:
    """A distorted vector magnetometer at DC and 25 C, eq. (1): h_r = S T h + o + n.

    Parameters
    ----------
    nonorthogonality_deg : (3,) angles v12, v13, v23, degrees
    scale_error : (3,) relative gain errors s_i
    offset : (3,) offsets o, nT
    noise : float
        White noise per axis, nT rms (drawn in :meth:`measure`).
    """

    def __init__(self, nonorthogonality_deg=(0.0, 0.0, 0.0), scale_error=(0.0, 0.0, 0.0),
                 offset=(0.0, 0.0, 0.0), noise=0.0):
        angles = np.radians(np.asarray(nonorthogonality_deg, dtype=float))
        self.angles_deg = np.degrees(angles)
        self.axes = axes_matrix(*angles)
        self.scale = 1.0 + np.asarray(scale_error, dtype=float)
        self.offset = np.array(offset, dtype=float)
        self.noise_nT = float(noise)

    @classmethod
    def random(cls, rng, nonorthogonality_deg=1.0, scale_error=0.005, offset=10.0, noise=0.1):
        """Errors drawn uniformly within the bounds (defaults: the paper's typical values, II.B)."""
        return cls(*(rng.uniform(-b, b, 3) for b in (nonorthogonality_deg, scale_error, offset)), noise)

    @property
    def distortion(self):
        """S T: raw = distortion @ h + offset."""
        return self.scale[:, None] * self.axes

    def measure(self, field, rng=None):
        """Raw readings (N, 3) nT of true field vectors (N, 3) nT in the sensor's orthogonal frame."""
        raw = field @ self.distortion.T + self.offset
        if self.noise_nT > 0:
            raw = raw + rng.normal(0.0, self.noise_nT, raw.shape)
        return raw

    def true_correction(self):
        """(matrix, offset) of the exact inverse, h = matrix (h_r - offset): the noise floor."""
        return np.linalg.inv(self.distortion), self.offset.copy()


class Fluxgate(Sensor):
    """A three-axis fluxgate plus front end, drawn from a preset and a seed.

    Parameters
    ----------
    preset : str
        "mag649" or "mag648".
    seed : int or None
        Fixes the sensor's errors (axes, gains, offsets, tempcos, front end).
        The noise realisation is drawn from `noise_rng` in :meth:`respond`.
    ideal : bool
        No errors at all (perfect axes, gains, offsets; nominal front end).
    **overrides
        Any key of COMMON / PRESETS (e.g. noise_nT=0.3, bandwidth_hz=None for
        an infinitely fast sensor).
    """

    def __init__(self, preset="mag649", seed=None, ideal=False, **overrides):
        if preset not in PRESETS:
            raise ValueError("unknown sensor %r (one of %s)" % (preset, ", ".join(PRESETS)))
        p = dict(COMMON, **PRESETS[preset])
        p.update({k: v for k, v in overrides.items() if v is not None or k == "bandwidth_hz"})
        self.preset, self.params = preset, p
        rng = np.random.default_rng(seed)
        k = 0.0 if ideal else 1.0

        def draw(bound):
            return k * rng.uniform(-bound, bound, 3)

        Sensor.__init__(self, draw(p["nonorthogonality_deg"]), draw(p["scale_error"]), draw(p["offset_nT"]),
                        p["noise_nT"])
        self.tempco_offset = draw(p["tempco_offset_nT_per_C"])
        self.tempco_scale = draw(p["tempco_scale_ppm_per_C"]) * 1e-6
        self.att = p["attenuation"] * (1.0 + draw(p["attenuation_tolerance"]))
        self.fe_offset = draw(p["frontend_offset_V"])
        self.bandwidth = p["bandwidth_hz"]
        self.pink_nT = float(p["pink_nT"])
        if p["poles"] not in (1, 2):
            raise ValueError("poles must be 1 or 2, got %r" % (p["poles"],))
        self.poles = p["poles"]
        # drawn last, and only when asked: the other errors of a seed stay what they were
        spread = rng.uniform(-1.0, 1.0, 3) * p["bandwidth_spread"] if p["bandwidth_spread"] else np.zeros(3)
        self.axis_bandwidth = None if not self.bandwidth else self.bandwidth * (1.0 + spread)

    @property
    def volts_per_nT_nominal(self):
        """Nominal front-end scale (V at the ADC per nT), what the firmware assumes."""
        return self.params["sensitivity_V_per_nT"] * self.params["attenuation"]

    def raw_model(self):
        """(A, c) with raw nT (nominal scale) = A b + c at 25 C, noise-free, DC.

        The calibration's job is to invert this: M = A^-1 up to a rotation,
        offset = c.
        """
        k = self.att / self.params["attenuation"]
        a = k[:, None] * self.distortion
        c = k * self.offset + self.fe_offset / self.volts_per_nT_nominal
        return a, c

    def reading(self, b, temp_c):
        """Noise-free sensor reading r (N, 3) nT, eq. (1), before bandwidth."""
        d = self.distortion
        r = np.empty_like(b)
        for i in range(3):                        # (N,3) @ (3,3) by columns: no slow matmul path
            r[:, i] = b[:, 0] * d[i, 0] + b[:, 1] * d[i, 1] + b[:, 2] * d[i, 2] + self.offset[i]
        if np.ndim(temp_c) or temp_c != 25.0:
            dt = (np.asarray(temp_c, dtype=float) - 25.0).reshape(-1, 1)
            r += (b @ d.T) * (self.tempco_scale * dt) + self.tempco_offset * dt
        return r

    def tau(self):
        """(3,) time constants (s) of the axes' poles: 1 / (2 pi f_pole); None: no bandwidth."""
        if not self.bandwidth:
            return None
        return 1.0 / (2.0 * np.pi * self.axis_bandwidth * (TWO_POLE_FACTOR if self.poles == 2 else 1.0))

    def bandlimit(self, r, rate_hz, state=None):
        """Per-axis low-pass at the sensor bandwidth (self.poles equal poles); returns (y, state).

        state: (poles, 3) outputs of each pole before the first sample, or None.
        """
        if not self.bandwidth:
            return r, None
        poles_hz = self.axis_bandwidth * (TWO_POLE_FACTOR if self.poles == 2 else 1.0)
        y = np.empty_like(np.asarray(r, dtype=float))
        out_state = np.empty((self.poles, 3))
        for i in range(3):
            a = alpha(poles_hz[i], rate_hz)
            x = r[:, i]
            for k in range(self.poles):
                x = lowpass(x, a, None if state is None else state[k, i])
                out_state[k, i] = x[-1]
            y[:, i] = x
        return y, out_state

    def to_volts(self, r):
        """ADC input volts (N, 3) for sensor readings r (N, 3) nT (after noise)."""
        return r * (self.params["sensitivity_V_per_nT"] * self.att) + self.fe_offset
