"""A surveyed site: buried iron, a pipe, magnetic soil and the day's drift.

    site = make_site(width_m=20, length_m=20, seed=3)
    field = SiteField(earth_vector(), site)        # B(t, position) like desktop.sim.field.Field

Site coordinates are the world frame's (x north, y east, z down, metres) with
the grid's south-west corner at the origin and the ground at z = 0; an object
at depth d sits at z = +d, the walked sensor at z = -0.3.

Sources (each adds a vector to the Earth field):

- **dipoles** (point iron): moment = induced part along the Earth field plus a
  remanent part in a random direction (0-50 % of it; remanence "can add x3-5",
  survey-practice.md s.3, this keeps most objects mostly induced).
  B = mu0/4pi (3 (m.r^) r^ - m) / r^3. Moments follow Geometrics' rule (1 t of
  iron gives 1 nT at 30 m: about 0.135 A m^2 per kg): from a nail (5 g) to a
  drum (hollow, reads heavier).
- **a pipe** (a line source across the whole site): moment per metre lambda,
  B = mu0/2pi (2 (lambda.rho^) rho^ - lambda_perp) / rho^2, rho the
  perpendicular distance from the pipe's axis (falls as 1/r^2).
- **soil clutter**: a sum of plane waves of 1-6 m wavelength along the Earth
  field, scaled to `clutter_ptp` nT peak-to-peak over the site (the paper's
  1-4 nT).
- **diurnal drift**: the day's variation (a 24 h sinusoid of `diurnal_nT`
  amplitude at a random phase) plus slow micropulsations (0.3 nT rms, 60 s),
  uniform over the site, along the Earth field.
"""

import numpy as np

from desktop.sim.field import MU0_4PI_NT, Field
from desktop.sim.filters import lowpass

# kind -> (moment range A m^2, depth range m): 0.135 A m^2 per kg of iron (Geometrics' rule)
CATALOGUE = {
    "nail": ((0.002, 0.01), (0.3, 0.5)),
    "horseshoe": ((0.03, 0.08), (0.3, 0.7)),
    "tool": ((0.1, 0.4), (0.4, 1.0)),
    "shell": ((0.5, 2.0), (0.6, 1.5)),
    "drum": ((8.0, 25.0), (1.2, 2.0)),
}
KINDS = tuple(CATALOGUE)
SENSOR_HEIGHT_M = 0.3
MIN_SEPARATION_M = 3.0        # objects far enough apart that each anomaly is its own
EDGE_M = 1.5                  # and inside the grid, where the walk sees their whole anomaly


class Site:
    """The buried objects and the site-wide fields. Build with :func:`make_site`."""

    def __init__(self, width_m, length_m, dipoles, pipe, clutter_ptp, diurnal_nT, seed):
        self.width_m, self.length_m = float(width_m), float(length_m)
        self.dipoles = dipoles          # list of dict(kind, x, y, depth, moment (3,))
        self.pipe = pipe                # dict(x, y (a point on it), azimuth_deg, depth, moment_per_m (3,)) or None
        self.clutter_ptp, self.diurnal_nT, self.seed = float(clutter_ptp), float(diurnal_nT), int(seed)
        rng = np.random.default_rng(np.random.SeedSequence([self.seed, 21]))
        n = 40
        wavelength = rng.uniform(1.0, 6.0, n)
        azimuth = rng.uniform(0.0, np.pi, n)
        self._k = (2 * np.pi / wavelength)[:, None] * np.c_[np.cos(azimuth), np.sin(azimuth)]
        self._phase = rng.uniform(0.0, 2 * np.pi, n)
        xs, ys = np.meshgrid(np.linspace(0, self.length_m, 81), np.linspace(0, self.width_m, 81))
        raw = self._waves(np.c_[xs.ravel(), ys.ravel()])
        self._clutter_scale = self.clutter_ptp / max(float(raw.max() - raw.min()), 1e-12)
        self._clutter_mean = float(raw.mean())
        self._day_phase = rng.uniform(0.0, 2 * np.pi)
        slow = lowpass(rng.standard_normal((4000, 1)), float(np.exp(-1.0 / 60.0)), np.zeros(1))[:, 0]
        self._pulsations = 0.3 * slow / max(float(slow.std()), 1e-12)      # one value per s, 4000 s

    def _waves(self, xy):
        return np.sin(xy @ self._k.T + self._phase).sum(axis=1)

    def clutter(self, xy):
        """(N,) soil anomaly, nT, at horizontal positions xy (N, 2) m."""
        return (self._waves(xy) - self._clutter_mean) * self._clutter_scale

    def diurnal(self, t):
        """(N,) the day's variation at times t (N,) s, nT (0 at t = 0)."""
        t = np.asarray(t, dtype=float)
        day = self.diurnal_nT * (np.sin(2 * np.pi * t / 86400.0 + self._day_phase) - np.sin(self._day_phase))
        i = np.clip(t, 0, len(self._pulsations) - 2)
        return day + np.interp(i, np.arange(len(self._pulsations)), self._pulsations) - self._pulsations[0]

    def objects_field(self, position):
        """(N, 3) field of the dipoles and the pipe at positions (N, 3) m, nT."""
        b = np.zeros((len(position), 3))
        for d in self.dipoles:
            r = position - np.array([d["x"], d["y"], d["depth"]])
            rn = np.linalg.norm(r, axis=1, keepdims=True)
            rh = r / rn
            m = np.asarray(d["moment"])
            b += MU0_4PI_NT * (3 * (rh @ m)[:, None] * rh - m) / rn ** 3
        if self.pipe:
            p = self.pipe
            u = _pipe_axis(p)
            rel = position - np.array([p["x"], p["y"], p["depth"]])
            rho = rel - np.outer(rel @ u, u)
            rn2 = np.einsum("ij,ij->i", rho, rho)[:, None]
            lam = np.asarray(p["moment_per_m"])
            lam = lam - (lam @ u) * u
            # mu0/2pi = 2 mu0/4pi
            b += 2 * MU0_4PI_NT * (2 * (rho @ lam)[:, None] * rho / rn2 - lam) / rn2
        return b

    def peak_nT(self, obj):
        """Largest total-field anomaly (dB . F^) of one object alone at the sensor's height, nT."""
        g = np.linspace(-3.0, 3.0, 121)
        gx, gy = np.meshgrid(g, g)
        pts = np.c_[obj["x"] + gx.ravel(), obj["y"] + gy.ravel(), np.full(gx.size, -SENSOR_HEIGHT_M)]
        alone = Site(self.width_m, self.length_m, [obj] if "moment" in obj else [],
                     obj if "moment_per_m" in obj else None, 0.0, 0.0, self.seed)
        return float((alone.objects_field(pts) @ self.field_dir).max())

    def to_dict(self):
        """JSON-ready description (the truth file's "site")."""
        def clean(o):
            return {k: (list(map(float, v)) if k.startswith("moment") else v) for k, v in o.items()}
        return {"width_m": self.width_m, "length_m": self.length_m, "seed": self.seed,
                "clutter_ptp_nT": self.clutter_ptp, "diurnal_nT": self.diurnal_nT,
                "dipoles": [dict(clean(d), peak_nT=round(self.peak_nT(d), 2)) for d in self.dipoles],
                "pipe": dict(clean(self.pipe), peak_nT=round(self.peak_nT(self.pipe), 2)) if self.pipe else None}


def _pipe_axis(pipe):
    a = np.radians(pipe["azimuth_deg"])
    return np.array([np.cos(a), np.sin(a), 0.0])


def make_site(width_m=20.0, length_m=20.0, seed=0, clutter_ptp=2.0, diurnal_nT=20.0, pipe=True,
              field_dir=(0.47, 0.02, 0.88)):
    """A site of buried objects drawn from `seed` (one of each kind, more on large sites).

    width_m is across the traverses (east), length_m along them (north).
    """
    if width_m <= 0 or length_m <= 0:
        raise ValueError("the site needs a positive width and length")
    if not 0 <= clutter_ptp <= 100:
        raise ValueError("clutter must be within 0..100 nT peak-to-peak")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 1]))
    f = np.asarray(field_dir, dtype=float) / np.linalg.norm(field_dir)
    count = max(len(KINDS), int(round(width_m * length_m / 50.0)))
    pipe_d = None
    if pipe:
        pipe_d = {"kind": "pipe", "x": float(rng.uniform(0.3, 0.7) * length_m),
                  "y": float(rng.uniform(0.3, 0.7) * width_m), "azimuth_deg": float(rng.uniform(20, 70)),
                  "depth": float(rng.uniform(0.8, 1.5))}
        pipe_d["moment_per_m"] = f * rng.uniform(0.2, 0.6)
    dipoles, tries = [], 0
    while len(dipoles) < count and tries < 2000:
        tries += 1
        kind = KINDS[len(dipoles) % len(KINDS)]
        (m_lo, m_hi), (d_lo, d_hi) = CATALOGUE[kind]
        x = rng.uniform(EDGE_M, max(length_m - EDGE_M, EDGE_M))
        y = rng.uniform(EDGE_M, max(width_m - EDGE_M, EDGE_M))
        if any(np.hypot(x - o["x"], y - o["y"]) < MIN_SEPARATION_M for o in dipoles):
            continue
        if pipe_d and _distance_to_pipe(pipe_d, x, y) < MIN_SEPARATION_M:
            continue
        size = np.exp(rng.uniform(np.log(m_lo), np.log(m_hi)))
        remanent = rng.standard_normal(3)
        remanent *= rng.uniform(0.0, 0.5) / np.linalg.norm(remanent)
        dipoles.append({"kind": kind, "x": float(x), "y": float(y), "depth": float(rng.uniform(d_lo, d_hi)),
                        "moment": size * (f + remanent)})
    site = Site(width_m, length_m, dipoles, pipe_d, clutter_ptp, diurnal_nT, seed)
    site.field_dir = f
    return site


def _distance_to_pipe(pipe, x, y):
    u = _pipe_axis(pipe)[:2]
    rel = np.array([x - pipe["x"], y - pipe["y"]])
    return float(abs(rel[0] * u[1] - rel[1] * u[0]))


class SiteField(Field):
    """The Earth field plus a :class:`Site`'s sources, B(t, position) in nT (world frame)."""

    def __init__(self, earth, site):
        Field.__init__(self, earth)
        self.site = site
        site.field_dir = self.direction

    @property
    def uniform(self):
        return False

    def at(self, t, position):
        """Field vectors (N, 3) nT at times t (N,) s and positions (N, 3) m.

        The site's sources change over centimetres, the walk moves a few millimetres
        between analog samples: the sources are evaluated every 2.5 ms at most and
        interpolated linearly between (the curvature error over 2.5 mm at 1 m/s is
        below 1e-4 of an anomaly whose source is 0.6 m away or more).
        """
        t = np.asarray(t, dtype=float)
        n = len(t)
        stride = 1 if n < 3 else max(1, int(0.0025 / max(t[1] - t[0], 1e-9)))
        idx = np.unique(np.r_[np.arange(0, n, stride), n - 1])
        p = position[idx]
        extra = self.site.objects_field(p)
        extra += np.outer(self.site.clutter(p[:, :2]) + self.site.diurnal(t[idx]), self.direction)
        b = np.empty((n, 3))
        for k in range(3):
            b[:, k] = np.interp(np.arange(n), idx, extra[:, k])
        return b + self.earth
