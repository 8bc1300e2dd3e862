"""The walking surveyor: the sensor carried along the traverses of a grid.

    walk = make_walk(rng, width_m=20, length_m=20, spacing_m=0.5, zigzag=True)
    walk.seconds, walk.line_marks        # how long it takes; (L, 2) marker presses, s

Traverses run north (world x) and step east (world y), the outer ones half a
line spacing inside the grid's edges (English Heritage practice, survey-practice.md
s.1). Line i lies at y = (i + 1/2) spacing; a zig-zag survey walks the odd lines
south, a parallel one walks every line north and returns to the south edge.

The walker presses the marker at the start and the end of each line (the times
in `line_marks`, with a human's +-30 ms), keeps `speed` m/s to a beeper's pace
(straying 5 cm rms from where the pace puts him, and catching up), turns at each line end (a
half circle onto the next line, 2.5 s; parallel: a turn on the spot, a walk back
at 1.5 m/s and a turn), and carries the sensor 0.3 m above ground with its x axis
ahead and z down, wobbling by up to 10 degrees (smooth, 4 degrees rms per axis,
plus the gait's 2 Hz roll) and bobbing 2 cm with the steps.
"""

import numpy as np

from desktop.sim.filters import lowpass
from desktop.sim.motion import Motion, qexp, qmul
from desktop.sim.site import SENSOR_HEIGHT_M

CONTROL_HZ = 100.0          # a walk has no content above a few Hz
LEAD_IN_S = 2.0             # standing at the first line's start before the first marker
TURN_S = 2.5
RETURN_SPEED = 1.5
MARK_JITTER_S = 0.03
PACE_ERROR_M = 0.05
WOBBLE_LIMIT_DEG = 10.0


class SurveyWalk(Motion):
    """A :class:`desktop.sim.motion.Motion` whose position is the walked path (site metres)."""

    def __init__(self, times, quats, path, line_marks, line_y, zigzag):
        Motion.__init__(self, "survey", times, quats, lever_m=0.0)
        self.path = path                # (K, 3) m at the control times
        self.line_marks = line_marks    # (L, 2) s: marker at each line's start and end
        self.line_y = line_y            # (L,) m: each line's east coordinate
        self.zigzag = zigzag
        self.seconds = float(times[-1])

    def position(self, t, q=None):
        i, j, f = self._locate(t)
        return self.path[i] + (self.path[j] - self.path[i]) * f[:, None]


def _smooth(rng, n, tau_s, dims=3):
    x = rng.standard_normal((n, dims))
    a = float(np.exp(-1.0 / (CONTROL_HZ * tau_s)))
    for _ in range(2):
        x = lowpass(x, a, np.zeros(dims))
    return x / max(float(x.std()), 1e-12)


def _line(rng, length_m, speed):
    """Along-line distance (K,) at CONTROL_HZ from 0 to length_m: the pace, and off it by
    PACE_ERROR_M rms (smooth, 2 s), as a walker keeping step with a beeper strays and catches up."""
    n = int(np.ceil(length_m / speed * CONTROL_HZ)) + 1
    t = np.arange(n) / CONTROL_HZ
    taper = np.sin(np.pi * np.clip(t / max(t[-1], 1e-9), 0, 1))      # on the marks at both ends
    s = speed * t + PACE_ERROR_M * _smooth(rng, n, 2.0, 1)[:, 0] * taper
    s = np.clip(np.maximum.accumulate(s), 0.0, length_m)
    s[-1] = length_m
    return s


def _turn(start_xy, end_xy, heading0, heading1, outward):
    """A half circle from start to end (m) beyond the line's end (outward: +1 north, -1 south)."""
    n = int(TURN_S * CONTROL_HZ)
    phi = np.linspace(0.0, np.pi, n + 1)[1:]
    centre = 0.5 * (np.asarray(start_xy) + end_xy)
    r = 0.5 * abs(end_xy[1] - start_xy[1])
    xy = np.c_[centre[0] + outward * r * np.sin(phi), centre[1] - r * np.cos(phi)]
    return xy, heading0 + (heading1 - heading0) * phi / np.pi


def _straight(start_xy, end_xy, speed, heading):
    d = float(np.hypot(*(np.asarray(end_xy) - start_xy)))
    n = max(int(d / speed * CONTROL_HZ), 1)
    f = np.arange(1, n + 1) / n
    return np.asarray(start_xy) + np.outer(f, np.asarray(end_xy) - start_xy), np.full(n, heading)


def _spin(xy, heading0, heading1, seconds):
    n = int(seconds * CONTROL_HZ)
    f = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, n + 1) / n)
    return np.tile(xy, (n, 1)), heading0 + (heading1 - heading0) * f


def make_walk(rng, width_m=20.0, length_m=20.0, spacing_m=0.5, zigzag=True, speed=1.0):
    """A :class:`SurveyWalk` over a width_m (east) x length_m (north) grid, lines spacing_m apart."""
    if not 0.1 <= spacing_m <= width_m:
        raise ValueError("line spacing must be within 0.1 m and the grid's width")
    if not 0.2 <= speed <= 3.0:
        raise ValueError("walking speed must be within 0.2..3 m/s")
    n_lines = max(int(round(width_m / spacing_m)), 1)
    line_y = (np.arange(n_lines) + 0.5) * spacing_m
    xy_parts, hd_parts, marks = [], [], []
    x0 = np.array([0.0, line_y[0]])
    xy, hd = np.tile(x0, (int(LEAD_IN_S * CONTROL_HZ), 1)), np.zeros(int(LEAD_IN_S * CONTROL_HZ))
    xy_parts.append(xy)
    hd_parts.append(hd)
    count = len(xy)
    for i, y in enumerate(line_y):
        north = not zigzag or i % 2 == 0
        heading = 0.0 if north else np.pi
        s = _line(rng, length_m, speed)
        x = s if north else length_m - s
        marks.append([count / CONTROL_HZ, (count + len(s) - 1) / CONTROL_HZ])
        xy_parts.append(np.c_[x, np.full(len(s), y)])
        hd_parts.append(np.full(len(s), heading))
        count += len(s)
        if i == n_lines - 1:
            break
        here = np.array([x[-1], y])
        if zigzag:
            nxt = np.array([x[-1], line_y[i + 1]])
            # a right turn going north, a left turn going south: heading 0 -> pi -> 0 (continuous)
            seg = _turn(here, nxt, heading, np.pi - heading, 1 if north else -1)
        else:
            a = _spin(here, 0.0, np.pi, 1.5)
            b = _straight(here, np.array([0.0, line_y[i + 1]]), RETURN_SPEED, np.pi)
            c = _spin(np.array([0.0, line_y[i + 1]]), np.pi, 2 * np.pi, 1.5)
            seg = (np.concatenate([a[0], b[0], c[0]]), np.concatenate([a[1], b[1], c[1]]) % (2 * np.pi))
        xy_parts.append(seg[0])
        hd_parts.append(seg[1])
        count += len(seg[0])
    tail = int(1.0 * CONTROL_HZ)              # a second standing at the end
    xy_parts.append(np.tile(xy_parts[-1][-1], (tail, 1)))
    hd_parts.append(np.full(tail, hd_parts[-1][-1]))
    xy, heading = np.concatenate(xy_parts), np.unwrap(np.concatenate(hd_parts))
    n = len(xy)
    t = np.arange(n) / CONTROL_HZ
    gait = 2 * np.pi * 2.0 * t
    height = -SENSOR_HEIGHT_M + 0.02 * np.sin(gait)
    path = np.c_[xy, height]
    # wobble: a smooth random rotation vector (4 deg rms), squashed below 10 deg, plus the gait's roll
    lim = np.radians(WOBBLE_LIMIT_DEG)
    w = np.radians(4.0) * _smooth(rng, n, 0.4)
    w = lim * np.tanh(w / lim)
    w[:, 0] += np.radians(3.0) * np.sin(0.5 * gait)
    yaw = qexp(np.outer(heading, [0.0, 0.0, 1.0]))
    q = qmul(yaw, qexp(w))
    jitter = rng.normal(0.0, MARK_JITTER_S, (len(marks), 2))
    return SurveyWalk(t, q, path, np.asarray(marks) + jitter, line_y, zigzag)
