"""The virtual operator: the sensor's orientation and position over time.

Orientation is a unit quaternion q = (w, x, y, z) rotating sensor-frame vectors
into the world frame (x north, y east, z down). Rotating motions integrate a
body-frame angular velocity omega(t) at a control rate:

    q_k = q_0 (x) dq_1 (x) ... (x) dq_k,   dq_k = exp(omega_k dt / 2)

computed for all k at once as a parallel prefix product (Hillis-Steele scan,
log2(N) vectorised passes), then interpolated to any time by normalised linear
interpolation (nlerp keeps |q| = 1, so a rotated vector keeps its length
exactly: interpolation never fakes smearing).

Motions (:func:`make_motion`):

- ``hand``: free tumbling by hand: omega is smooth random (two cascaded
  low-passes, tau = 0.25 s) with mean |omega| = `rate` rev/s (the paper: about
  1 rev/s), plus a faster tremor component (tau = 0.03 s, 20 %), soft-limited
  to 3 x `rate` (a wrist does not spin freely). With `coverage` < 1 the hand
  stays within a cap: q = q_0 exp(r(t)) with the rotation vector |r| <= theta,
  so the field direction seen by the sensor stays in a cap of area fraction
  `coverage` ((1 - cos theta) / 2 = coverage).
- ``guided``: a systematic pattern: full turns about the body x, y, z axes and
  the four body diagonals in turn, each ramped smoothly, repeated.
- ``spin``: a steady turn about the world vertical at `rate` rev/s from a
  random tilted attitude (the paper's Fig. 6 verification).
- ``uniform`` / ``cap``: the paper's synthetic sampling (section IV.D): the
  sensor jumps between attitudes drawn uniformly over the whole sphere of field
  directions / over a cap of area fraction `coverage`, holding each for `dwell`.
- ``stationary``: one fixed attitude.

The sensor sits on a lever of `lever_m` from the wrist pivot, which sways
slowly (`sway_m` rms, tau = 2 s): the position follows the hand, which matters
in a field gradient.
"""

import numpy as np

from desktop.sim.filters import lowpass

MOTIONS = ("hand", "guided", "spin", "uniform", "cap", "stationary")
CONTROL_RATE = 400.0        # Hz; hand motion has no content near 200 Hz


# ----------------------------------------------------------------- quaternions
def qmul(a, b):
    """Hamilton product of (..., 4) quaternion arrays."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def qexp(rotvec):
    """Quaternions (..., 4) of rotation vectors (..., 3), rad (axis * angle)."""
    rotvec = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(x/2)/x without 0/0: its series below 1e-8 rad
    k = np.where(angle > 1e-8, np.sin(half) / np.where(angle > 1e-8, angle, 1.0), 0.5)
    return np.concatenate([np.cos(half), k * rotvec], axis=-1)


def rotate(q, v, inverse=False):
    """Rotate vectors v (N, 3) by unit quaternions q (N, 4) (inverse: by q*).

    v' = v + 2w (u x v) + 2 u x (u x v), u = (x, y, z).
    """
    w = q[..., :1]
    u = -q[..., 1:] if inverse else q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def to_sensor(q, v_world):
    """World-frame vectors (N, 3) (or one (3,)) in the sensor frame: R(q)^T v.

    Written out with the rotation matrix's entries: on long arrays this is
    several times faster than the cross-product form of :func:`rotate`.
    """
    w, x, y, z = q.T
    v = np.asarray(v_world, dtype=float)
    vx, vy, vz = (v[0], v[1], v[2]) if v.ndim == 1 else v.T
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    # columns of R are the sensor axes in the world: b_i = sum_j R_ji v_j
    out = np.empty((len(w), 3))
    out[:, 0] = (1 - 2 * (yy + zz)) * vx + 2 * (xy + wz) * vy + 2 * (xz - wy) * vz
    out[:, 1] = 2 * (xy - wz) * vx + (1 - 2 * (xx + zz)) * vy + 2 * (yz + wx) * vz
    out[:, 2] = 2 * (xz + wy) * vx + 2 * (yz - wx) * vy + (1 - 2 * (xx + yy)) * vz
    return out


SCAN_BLOCK = 1 << 16      # up to this many points (164 s at 400 Hz) scan_product is one scan
_ROW = 64                 # longer: rows of this many points, multiplied out along the row


def _scan(q):
    """Hillis-Steele inclusive prefix product in place along axis -2 of (..., N, 4)."""
    s = 1
    while s < q.shape[-2]:
        q[..., s:, :] = qmul(q[..., :-s, :], q[..., s:, :])
        s *= 2
    return q


def scan_product(dq):
    """Inclusive prefix product dq_0 (x) dq_1 (x) ... (x) dq_k, (N, 4).

    Up to SCAN_BLOCK points one Hillis-Steele scan (log2(N) vectorised passes over all
    points). Longer motions (hours) in two levels: the points as rows of _ROW, each row's
    products along it (_ROW vectorised steps over N / _ROW rows), the rows' totals scanned,
    then each row turned by the product of the rows before it: about 2 N quaternion
    products instead of N log2(N) (the same products, associated otherwise: equal to
    rounding).
    """
    q = np.array(dq, dtype=float)
    n = len(q)
    if n <= SCAN_BLOCK:
        q = _scan(q)
    else:
        rows = -(-n // _ROW)
        ident = np.tile([1.0, 0.0, 0.0, 0.0], (rows * _ROW - n, 1))
        # column j of every row side by side in memory: (_ROW, rows, 4)
        qc = np.ascontiguousarray(np.concatenate([q, ident]).reshape(rows, _ROW, 4).transpose(1, 0, 2))
        for j in range(1, _ROW):
            qc[j] = qmul(qc[j - 1], qc[j])
        carry = _scan(qc[-1].copy())        # the product of every row up to and with this one
        qc[:, 1:] = qmul(carry[None, :-1], qc[:, 1:])
        q = qc.transpose(1, 0, 2).reshape(-1, 4)[:n]
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def continuous(q):
    """Flip signs so consecutive quaternions are on the same hemisphere (for nlerp)."""
    q = np.array(q, dtype=float)
    dots = np.einsum("ij,ij->i", q[1:], q[:-1])
    flip = np.concatenate([[1.0], np.cumprod(np.where(dots < 0, -1.0, 1.0))])
    return q * flip[:, None]


def random_quaternions(rng, n):
    """n uniformly distributed rotations (Shoemake), (n, 4)."""
    u1, u2, u3 = rng.random((3, n))
    a, b = np.sqrt(1 - u1), np.sqrt(u1)
    return np.stack([a * np.sin(2 * np.pi * u2), a * np.cos(2 * np.pi * u2),
                     b * np.sin(2 * np.pi * u3), b * np.cos(2 * np.pi * u3)], axis=1)


def align(frm, to):
    """Quaternions (N, 4) of the shortest rotations taking unit vectors frm to to."""
    frm, to = np.broadcast_arrays(np.asarray(frm, float), np.asarray(to, float))
    w = 1.0 + np.einsum("ij,ij->i", frm, to)
    q = np.concatenate([w[:, None], np.cross(frm, to)], axis=1)
    anti = w < 1e-9                               # opposite: any perpendicular axis
    if anti.any():
        perp = np.cross(frm[anti], [1.0, 0.0, 0.0])
        small = np.linalg.norm(perp, axis=1) < 1e-6
        perp[small] = np.cross(frm[anti][small], [0.0, 1.0, 0.0])
        q[anti] = np.concatenate([np.zeros((anti.sum(), 1)), perp], axis=1)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def cap_angle(coverage):
    """Half-angle (rad) of a spherical cap holding `coverage` of the sphere's area."""
    return float(np.arccos(1.0 - 2.0 * np.clip(coverage, 1e-6, 1.0)))


def directions_in_cap(rng, n, centre, coverage):
    """n unit vectors uniform over the cap of area fraction `coverage` around `centre`."""
    z = 1.0 - 2.0 * np.clip(coverage, 1e-6, 1.0) * rng.random(n)   # uniform in cos
    phi = 2 * np.pi * rng.random(n)
    r = np.sqrt(np.clip(1 - z * z, 0, None))
    local = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    return rotate(np.repeat(align([[0.0, 0.0, 1.0]], [centre]), n, axis=0), local)


# -------------------------------------------------------------------- motion
class Motion:
    """Orientation and position of the sensor as functions of time.

    Parameters
    ----------
    times : (K,) float array, s
        Control times (uniform, or hold points for piecewise-constant motion).
    quats : (K, 4) float array
        Orientation at the control times (sign-continuous).
    hold : bool
        True: piecewise constant (jumps); False: nlerp between control points.
    lever_m, sway : see module docstring; sway is (K, 3) m at the control times.
    """

    def __init__(self, name, times, quats, hold=False, lever_m=0.25, sway=None):
        self.name = name
        self.times = np.asarray(times, dtype=float)
        self.quats = continuous(quats)
        self.hold = hold
        self.lever = np.array([lever_m, 0.0, 0.0])
        self.sway = np.zeros((len(self.times), 3)) if sway is None else sway

    def _locate(self, t):
        t = np.asarray(t, dtype=float)
        last = len(self.times) - 1
        if self.hold or last < 1:
            i = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, last)
            return i, i, None
        # uniform control grid: index arithmetic instead of a search
        k = (t - self.times[0]) * (last / (self.times[-1] - self.times[0]))
        i = np.clip(k.astype(np.int64), 0, last - 1)
        return i, i + 1, np.clip(k - i, 0.0, 1.0)

    def orientation(self, t):
        """(N, 4) unit quaternions (sensor to world) at times t (N,), s."""
        i, j, f = self._locate(t)
        if f is None:
            return self.quats[i]
        q = self.quats[i]
        q += (self.quats[j] - q) * f[:, None]
        return q / np.sqrt(np.einsum("ij,ij->i", q, q))[:, None]

    def position(self, t, q=None):
        """(N, 3) sensor position in m (world frame, relative to the wrist's mean)."""
        i, j, f = self._locate(t)
        q = self.orientation(t) if q is None else q
        w, x, y, z = q.T
        # R(q) (L, 0, 0): L times R's first column
        p = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)], axis=1)
        p *= self.lever[0]
        if self.sway.any():
            sway = self.sway[i] if f is None else self.sway[i] + (self.sway[j] - self.sway[i]) * f[:, None]
            p += sway
        return p


def _smooth_noise(rng, n, dt, tau, order=2):
    """(n, 3) zero-mean unit-rms smooth random process (cascaded low-passes)."""
    x = rng.standard_normal((n, 3))
    a = float(np.exp(-dt / tau))
    for _ in range(order):
        x = lowpass(x, a, np.zeros(3))
    return x / max(float(x.std()), 1e-12)


def _sway(rng, n, dt, sway_m):
    return sway_m * _smooth_noise(rng, n, dt, 2.0) if sway_m else np.zeros((n, 3))


def _hand_free(rng, t, rate):
    dt = t[1] - t[0]
    omega_typ = 2 * np.pi * rate
    # E|w| = 1.596 sigma for a 3-D Gaussian: sigma so that the mean rate is `rate`
    w = (_smooth_noise(rng, len(t), dt, 0.25) + 0.2 * _smooth_noise(rng, len(t), dt, 0.03)) \
        * (omega_typ / 1.596 / np.sqrt(1.04))
    mag = np.linalg.norm(w, axis=1, keepdims=True)
    limit = 3.0 * omega_typ                      # soft wrist limit
    w *= limit * np.tanh(mag / limit) / np.maximum(mag, 1e-12)
    dq = qexp(w * dt)
    dq[0] = random_quaternions(rng, 1)[0]        # q_0: a random starting attitude
    return scan_product(dq)


def _hand_cap(rng, t, rate, coverage, field_dir):
    dt = t[1] - t[0]
    theta = cap_angle(coverage)
    # r(t): smooth random rotation vector; its speed ~ rate, squashed to |r| < theta
    u = _smooth_noise(rng, len(t), dt, 0.25)
    u = np.cumsum(u, axis=0) * dt * 2 * np.pi * rate / 1.596
    u -= lowpass(u, float(np.exp(-dt / 3.0)), np.zeros(3))        # no slow wander off
    mag = np.linalg.norm(u, axis=1, keepdims=True)
    r = u * (theta * np.tanh(mag / theta) / np.maximum(mag, 1e-12))
    # q0 puts the world field direction at the cap centre (a random sensor direction)
    centre = directions_in_cap(rng, 1, [0.0, 0.0, 1.0], 1.0)
    q0 = align(centre, [field_dir])
    # field in sensor frame d = exp(-r) c: stays within |r| of the centre
    return qmul(np.repeat(q0, len(t), axis=0), qexp(r))


def _guided(rng, t, rate):
    dt = t[1] - t[0]
    axes = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [1, -1, 1],
                     [-1, 1, 1], [1, 1, -1]], dtype=float)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    turn = 1.0 / rate                             # s per full turn at the plateau
    ramp = 0.25 * turn
    seg = turn + ramp                             # raised-cosine ramps: same area as turn
    k = (t // seg).astype(int)
    s = t - k * seg
    env = np.clip(np.minimum(s, seg - s) / ramp, 0.0, 1.0)
    env = 0.5 - 0.5 * np.cos(np.pi * env)
    w = axes[k % len(axes)] * (2 * np.pi * rate * env)[:, None]
    w += 0.1 * 2 * np.pi * rate * _smooth_noise(rng, len(t), dt, 0.3)   # an imperfect hand
    dq = qexp(w * dt)
    dq[0] = random_quaternions(rng, 1)[0]
    return scan_product(dq)


def make_motion(name, seconds, rng, *, rate=1.0, coverage=1.0, field_dir=(1.0, 0.0, 0.0),
                dwell=0.002, lever_m=0.25, sway_m=0.02):
    """Build a :class:`Motion`.

    Parameters
    ----------
    name : str
        One of MOTIONS.
    seconds : float
        Duration, s.
    rng : numpy.random.Generator
        The motion's own generator (`--motion-seed`).
    rate : float
        Typical rotation rate, rev/s.
    coverage : float
        Fraction of the sphere of field directions the motion may reach (hand, cap).
    field_dir : (3,) unit vector
        World direction of the field (to place the cap).
    dwell : float
        Hold time per attitude for uniform / cap, s.
    """
    if name not in MOTIONS:
        raise ValueError("unknown motion %r (one of %s)" % (name, ", ".join(MOTIONS)))
    field_dir = np.asarray(field_dir, float) / np.linalg.norm(field_dir)
    if name in ("uniform", "cap"):
        n = max(int(np.ceil(seconds / dwell)), 1) + 1
        times = np.arange(n) * dwell
        cov = 1.0 if name == "uniform" else coverage
        centre = directions_in_cap(rng, 1, [0.0, 0.0, 1.0], 1.0)[0]
        d = directions_in_cap(rng, n, centre, cov)            # sensor-frame field directions
        roll = qexp(field_dir[None, :] * (2 * np.pi * rng.random(n))[:, None])
        q = qmul(roll, align(d, field_dir[None, :]))          # R d = field_dir, random roll
        return Motion(name, times, q, hold=True, lever_m=lever_m)
    n = int(np.ceil(seconds * CONTROL_RATE)) + 2
    if name == "stationary":
        # one attitude: two control points span the motion (nlerp between equal
        # quaternions gives the quaternion itself, as n equal points did)
        return Motion(name, [0.0, (n - 1) / CONTROL_RATE], np.repeat(random_quaternions(rng, 1), 2, axis=0),
                      lever_m=lever_m)
    t = np.arange(n) / CONTROL_RATE
    if name == "spin":
        q0 = random_quaternions(rng, 1)
        q = qmul(qexp(np.outer(2 * np.pi * rate * t, [0.0, 0.0, 1.0])), np.repeat(q0, n, axis=0))
    elif name == "guided":
        q = _guided(rng, t, rate)
    elif coverage >= 1.0:
        q = _hand_free(rng, t, rate)
    else:
        q = _hand_cap(rng, t, rate, coverage, field_dir)
    return Motion(name, t, q, lever_m=lever_m, sway=_sway(rng, n, 1 / CONTROL_RATE, sway_m))


def rotation_rate(motion, t):
    """Angular speed |omega| (rad/s) at times t (N,), from the orientation's change."""
    h = 1e-3
    qa, qb = motion.orientation(t - h), motion.orientation(t + h)
    dots = np.abs(np.einsum("ij,ij->i", qa, qb)).clip(0, 1)
    return 2 * np.arccos(dots) / (2 * h)
