"""Point samples of the simulated sensor: field directions in, raw nT out.

No time, no bandwidth, no ADC: the sensor model of eq. (1) (sensor.Sensor)
applied to direction sets drawn with the operator model of motion.py. For
the core's tests and benchmarks, where a capture in time would only add cost.

    from desktop.sim.field import EARTH_NT
    from desktop.sim.sensor import Sensor
    rng = np.random.default_rng(0)
    sensor = Sensor.random(rng)                              # the paper's typical errors
    raw = sensor.measure(EARTH_NT * directions("cap", rng, 3000, 0.26), rng)   # (N, 3) nT

Direction sets, (N, 3) unit vectors in the sensor frame: ``uniform`` over the
sphere, ``cap`` (a spherical cap holding a given fraction of its area) and
``tumble`` (the field seen by a sensor turned by hand, motion.py's ``hand``).
"""

import numpy as np

from desktop.sim.motion import directions_in_cap, make_motion, to_sensor

DIRECTION_SETS = ("uniform", "cap", "tumble")


def uniform_directions(rng, n):
    """(n, 3) unit vectors uniform on the sphere."""
    return directions_in_cap(rng, n, (0.0, 0.0, 1.0), 1.0)


def cap_directions(rng, n, fraction, axis=None):
    """(n, 3) unit vectors uniform on a cap holding `fraction` of the sphere's area,
    centred on `axis` (default: a random direction)."""
    if not 0 < fraction <= 1:
        raise ValueError("fraction must be in (0, 1], got %r" % fraction)
    centre = uniform_directions(rng, 1)[0] if axis is None else np.asarray(axis, dtype=float)
    return directions_in_cap(rng, n, centre / np.linalg.norm(centre), fraction)


def tumble_directions(rng, n, rate_hz=100.0, rev_per_s=1.0, field_dir=(0.0, 0.0, 1.0)):
    """(n, 3) field directions, sampled at `rate_hz`, in the frame of a sensor turned by
    hand at about `rev_per_s` (motion.py's ``hand``: smooth, uneven over the sphere)."""
    motion = make_motion("hand", n / rate_hz, rng, rate=rev_per_s)
    field = np.asarray(field_dir, dtype=float)
    return to_sensor(motion.orientation(np.arange(n) / rate_hz), field / np.linalg.norm(field))


def directions(kind, rng, n, coverage=1.0):
    """Direction set by name: 'uniform', 'cap' (with coverage) or 'tumble'."""
    if kind == "uniform":
        return uniform_directions(rng, n)
    if kind == "cap":
        return cap_directions(rng, n, coverage)
    if kind == "tumble":
        return tumble_directions(rng, n)
    raise ValueError("unknown direction set %r (one of %s)" % (kind, ", ".join(DIRECTION_SETS)))
