"""Anomalies in a processed survey: found on the grid, placed by a source fit, depth by half-width.

Detection: local maxima of the gridded anomaly over THRESHOLD_SIGMAS robust sigmas
of the map's quiet background (the soil's clutter and the sensor's noise set that
sigma, :func:`background_sigma`) that stand half that threshold over their
surroundings 2 m away, the weaker of two within SEPARATION_M dropped. A maximum whose anomaly stays above half its peak
2 m away on both sides in some direction is *linear* (a pipe, a ditch, a fence).

Position: an induced anomaly's peak is not above its source (at 62 deg inclination
the positive lobe sits south of it, survey-practice.md s.3), so each one is placed
by a least-squares source fit to the traverse samples within FIT_RADIUS_M: a point
dipole (x, y, depth) for a compact anomaly, a horizontal line source (offset, depth)
along the linear direction for a linear one. The moments are linear in the field
and solved exactly for each trial position (variable projection); the position by
Levenberg-Marquardt from a few starting depths.

Depth: also by the half-width rule for a sphere (depth below the sensor ~ 2 x the
half-width at half maximum, SEG's half-width method) from the map's east-west
profile through the peak, which an inclined field leaves symmetric.
"""

import numpy as np

from desktop.survey.processing import robust_sigma

THRESHOLD_SIGMAS = 6.0
MIN_THRESHOLD_NT = 1.0
SEPARATION_M = 1.5
FIT_RADIUS_M = 2.5
MU0_4PI_NT = 100.0


class Anomaly:
    def __init__(self, north_m, east_m, peak_nT, kind):
        self.north_m, self.east_m, self.peak_nT, self.kind = north_m, east_m, peak_nT, kind
        self.peak_north_m, self.peak_east_m = north_m, east_m
        self.depth_halfwidth_m = self.depth_fit_m = float("nan")
        self.fit_rms_nT = float("nan")
        self.azimuth_deg = None

    def summary(self):
        where = "%.2f m N, %.2f m E" % (self.north_m, self.east_m)
        depth = "depth %.1f m (fit), %.1f m (half-width)" % (self.depth_fit_m, self.depth_halfwidth_m)
        if self.kind == "linear":
            return "linear anomaly %+.1f nT through %s, striking %.0f deg, %s" % (
                self.peak_nT, where, self.azimuth_deg, depth)
        return "anomaly %+.1f nT at %s, %s" % (self.peak_nT, where, depth)


def _local_maxima(grid, threshold):
    v = grid.values
    p = np.pad(v, 2, mode="edge")
    is_max = v > threshold
    for di in range(-2, 3):
        for dj in range(-1, 2):
            if di or dj:
                is_max &= v >= p[2 + di:2 + di + v.shape[0], 2 + dj:2 + dj + v.shape[1]]
    i, j = np.nonzero(is_max)
    order = np.argsort(-v[i, j])
    kept = []
    for k in order:
        n, e = grid.north_m[i[k]], grid.east_m[j[k]]
        if all(np.hypot(n - a, e - b) >= SEPARATION_M for a, b, _ in kept):
            kept.append((n, e, float(v[i[k], j[k]])))
    return kept


def _linear_direction(grid, n, e, peak):
    """Azimuth (deg from north) along which the anomaly stays above half its peak 2 m both ways, or None."""
    best = None
    for az in np.arange(0.0, 180.0, 7.5):
        a = np.radians(az)
        dn, de = 2.0 * np.cos(a), 2.0 * np.sin(a)
        both = grid.sample(np.array([n + dn, n - dn]), np.array([e + de, e - de]))
        if both.min() > 0.5 * peak and (best is None or both.min() > best[1]):
            best = (az, both.min())
    return None if best is None else best[0]


def half_width_depth(grid, n, e, peak, sensor_height_m):
    """Depth below ground (m) by the half-width rule from the east-west profile through (n, e)."""
    east = np.linspace(grid.east_m[0], grid.east_m[-1], 801)
    prof = grid.sample(np.full(len(east), n), east)
    k = int(np.argmin(np.abs(east - e)))
    widths = []
    for side in (slice(k, None), slice(k, None, -1)):
        seg, pos = prof[side], east[side]
        below = np.nonzero(seg < 0.5 * peak)[0]
        if len(below):
            widths.append(abs(pos[below[0]] - e))
    return 2.0 * float(np.mean(widths)) - sensor_height_m if widths else float("nan")


def dipole_kernel(points, src, fdir):
    """(P, 3) total-field response F^.B of unit moments along x, y, z at src to points (P, 3)."""
    r = points - src
    rn = np.linalg.norm(r, axis=1, keepdims=True)
    rh = r / rn
    return MU0_4PI_NT * (3 * rh * (rh @ fdir)[:, None] - fdir) / rn ** 3


def line_kernel(points, through, azimuth_deg, fdir):
    """(P, 2) response of unit moments per metre (horizontal across, vertical) of a horizontal line."""
    a = np.radians(azimuth_deg)
    u = np.array([np.cos(a), np.sin(a), 0.0])
    rel = points - through
    rho = rel - np.outer(rel @ u, u)
    rn2 = np.einsum("ij,ij->i", rho, rho)[:, None]
    cols = []
    for lam in (np.array([-u[1], u[0], 0.0]), np.array([0.0, 0.0, 1.0])):
        b = 2 * MU0_4PI_NT * (2 * (rho @ lam)[:, None] * rho / rn2 - lam) / rn2
        cols.append(b @ fdir)
    return np.stack(cols, axis=1)


def _residual(design, values, points):
    # the moments, a level per traverse (what destriping or heading error left on each line)
    # and a north slope (another source's tail, the soil's): all linear in the fit
    _, line = np.unique(points[:, 1], return_inverse=True)
    per_line = (line[:, None] == np.arange(line.max() + 1)[None, :]).astype(float)
    a = np.c_[design, per_line, points[:, 0] - points[:, 0].mean()]
    coef, *_ = np.linalg.lstsq(a, values, rcond=None)
    return values - a @ coef


def _levenberg_marquardt(fun, x0, lower, upper, iterations=40):
    x = np.clip(np.asarray(x0, dtype=float), lower, upper)
    r = fun(x)
    cost, lam = float(r @ r), 1e-2
    for _ in range(iterations):
        jac = np.empty((len(r), len(x)))
        for k in range(len(x)):
            h = np.zeros(len(x))
            h[k] = 1e-4
            jac[:, k] = (fun(np.clip(x + h, lower, upper)) - r) / 1e-4
        g, jtj = jac.T @ r, jac.T @ jac
        step = np.linalg.solve(jtj + lam * np.diag(np.diag(jtj) + 1e-12), -g)
        trial = np.clip(x + step, lower, upper)
        rt = fun(trial)
        if float(rt @ rt) < cost:
            x, r, cost, lam = trial, rt, float(rt @ rt), lam / 3
            if np.abs(step).max() < 1e-4:
                break
        else:
            lam *= 4
    return x, cost


def fit_position(anom, samples, fdir, sensor_height_m):
    """Place `anom` by a source fit to samples (north, east, nT) (S, 3) near it; sets its position and depth."""
    # the window: about twice the source's distance (its anomaly's extent), 1..FIT_RADIUS_M
    reach = anom.depth_halfwidth_m + sensor_height_m
    radius = float(np.clip(2.0 * reach, 1.0, FIT_RADIUS_M)) if np.isfinite(reach) else FIT_RADIUS_M
    near = np.hypot(samples[:, 0] - anom.peak_north_m, samples[:, 1] - anom.peak_east_m) <= radius
    s = samples[near]
    if len(s) < 12:
        return
    pts = np.c_[s[:, 0], s[:, 1], np.full(len(s), -sensor_height_m)]
    n0, e0 = anom.peak_north_m, anom.peak_east_m
    if anom.kind == "linear":
        a = np.radians(anom.azimuth_deg)
        across = np.array([-np.sin(a), np.cos(a)])

        def fun(x):
            c = np.array([n0 + x[0] * across[0], e0 + x[0] * across[1], x[1]])
            return _residual(line_kernel(pts, c, anom.azimuth_deg, fdir), s[:, 2], pts)
        lower, upper, starts = np.array([-1.5, 0.05]), np.array([1.5, 4.0]), [[0.0, z] for z in (0.4, 1.0, 2.0)]
    else:
        def fun(x):
            return _residual(dipole_kernel(pts, np.array(x), fdir), s[:, 2], pts)
        lower = np.array([n0 - 1.5, e0 - 1.5, 0.05])
        upper = np.array([n0 + 1.5, e0 + 1.5, 4.0])
        starts = [[n0 + 0.3 * z * fdir[0] / max(fdir[2], 0.1), e0, z] for z in (0.4, 1.0, 2.0)]
    best = min((_levenberg_marquardt(fun, x0, lower, upper) for x0 in starts), key=lambda r: r[1])
    x, cost = best
    if anom.kind == "linear":
        anom.north_m, anom.east_m = n0 + x[0] * across[0], e0 + x[0] * across[1]
    else:
        anom.north_m, anom.east_m = float(x[0]), float(x[1])
    anom.depth_fit_m = float(x[-1])
    anom.fit_rms_nT = float(np.sqrt(cost / len(s)))


def background_sigma(grid, tile_m=3.0):
    """The map's quiet background (soil clutter and sensor noise), sigma in nT.

    On a small site the buried objects' own anomalies (a drum's 1/r^3 tails, a pipe's
    ridge) cover much of the grid, so the whole map's spread is not its noise: the
    grid is cut into tiles of about tile_m, each tile's plane (the tails' slope)
    removed, and the quietest quarter of the tiles' robust sigmas taken.
    """
    ni = max(int(round(tile_m / max(grid.cell_m()[0], 1e-6))), 4)
    nj = max(int(round(tile_m / max(grid.cell_m()[1], 1e-6))), 2)
    sigmas = []
    for i in range(0, grid.values.shape[0] - ni // 2, ni):
        for j in range(0, grid.values.shape[1] - nj // 2, nj):
            v = grid.values[i:i + ni, j:j + nj]
            if v.size < 8:
                continue
            ii, jj = np.meshgrid(np.arange(v.shape[0]), np.arange(v.shape[1]), indexing="ij")
            a = np.c_[ii.ravel(), jj.ravel(), np.ones(v.size)]
            coef, *_ = np.linalg.lstsq(a, v.ravel(), rcond=None)
            sigmas.append(robust_sigma(v.ravel() - a @ coef))
    return float(np.percentile(sigmas, 25)) if sigmas else robust_sigma(grid.values)


def _prominence(grid, n, e, radius_m=2.0):
    """A maximum's height over the median of the map on a circle of radius_m around it (a slope cancels)."""
    ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    ring = grid.sample(n + radius_m * np.cos(ang), e + radius_m * np.sin(ang))
    return float(grid.sample(np.array([n]), np.array([e]))[0] - np.median(ring))


def find_anomalies(grid, samples, fdir, sensor_height_m=0.3, threshold_nT=None):
    """(list of Anomaly, threshold nT): detection on `grid`, placement by fits to `samples` (S, 3)."""
    sigma = background_sigma(grid)
    threshold = threshold_nT if threshold_nT is not None else max(THRESHOLD_SIGMAS * sigma, MIN_THRESHOLD_NT)
    found = []
    for n, e, peak in _local_maxima(grid, threshold):
        if _prominence(grid, n, e) < 0.5 * threshold:
            continue            # a ripple on another anomaly's slope, not a source of its own
        az = _linear_direction(grid, n, e, peak)
        anom = Anomaly(n, e, peak, "linear" if az is not None else "compact")
        anom.azimuth_deg = az
        anom.depth_halfwidth_m = half_width_depth(grid, n, e, peak, sensor_height_m)
        found.append(anom)
    found = _merge_linear(found)
    for anom in found:
        fit_position(anom, samples, np.asarray(fdir, dtype=float), sensor_height_m)
    return found, threshold


def _merge_linear(found):
    """One entry per linear feature: a linear anomaly on the line of a stronger one (within
    0.5 m of it, striking within 20 deg) is the same feature, and dropped."""
    kept = []
    for a in found:
        same = False
        if a.kind == "linear":
            for b in kept:
                if b.kind != "linear" or abs((a.azimuth_deg - b.azimuth_deg + 90) % 180 - 90) > 20:
                    continue
                u = np.radians(b.azimuth_deg)
                off = abs((a.north_m - b.north_m) * np.sin(u) - (a.east_m - b.east_m) * np.cos(u))
                same = same or off < 0.5
        if not same:
            kept.append(a)
    return kept
