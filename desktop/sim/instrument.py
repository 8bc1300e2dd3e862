"""A realistic instrument in ADC codes: what the interpreters' precision is judged on.

    fit_codes, spin_codes, field = realistic_instrument()
    cal = desktop.methods.fit_array(fit_codes.astype(float), field=field)   # the reference fit

48,000 nT, axes 1 degree from orthogonal, gains within 0.5 %, 300 nT offsets
(desktop.sim.sensor.Sensor.random), front-end offsets of a few million codes and
0.0096 nT per code, so codes reach 7.6 million (23 bits): a 30-bit float's 22-bit
significand cannot hold them. `fit_codes` are uniform directions (the users fit them in
CPython for the reference calibration); `spin_codes` are a 360 degree spin at 37 degrees from
the vertical.
Used by tests/test_shared_on_micropython.py and python -m desktop.bench.interpreters.
"""

import numpy as np

from desktop.sim.points import uniform_directions
from desktop.sim.sensor import Sensor

FIELD_NT = 48000.0
NT_PER_CODE = 0.0096
FRONT_END = (3.4e6, -3.1e6, 3.6e6)


def realistic_instrument(seed=5, n_fit=4000, n_spin=400):
    """(fit codes (n_fit, 3), spin codes (n_spin, 3), field nT), integer codes."""
    rng = np.random.default_rng(seed)
    sensor = Sensor.random(rng, 1.0, 0.005, 300.0, 0.0)
    front_end = np.array(FRONT_END)
    fit_codes = np.rint(sensor.measure(FIELD_NT * uniform_directions(rng, n_fit)) / NT_PER_CODE
                        + front_end).astype(np.int64)
    t = np.linspace(0, 2 * np.pi, n_spin, endpoint=False)
    d = np.column_stack([0.6 * np.cos(t), 0.6 * np.sin(t), np.full_like(t, 0.8)])
    spin_codes = np.rint(sensor.measure(FIELD_NT * d) / NT_PER_CODE + front_end).astype(np.int64)
    return fit_codes, spin_codes, FIELD_NT
