"""The interpreters a board has, as test parameters (desktop/firmware/interpreters.py builds them).

A test parametrised with INTERPRETERS runs once per interpreter. One that is not
built on this machine is skipped, saying so in one line; with
FLUXCAL_REQUIRE_INTERPRETERS=1 (set by .ci/run) it fails instead, so CI runs them all.
"""

import os

import pytest

from desktop.firmware.interpreters import FLOAT_BITS, UNIX, interpreter

INTERPRETERS = UNIX


def need(name):
    """Path of the interpreter, or skip (fail under FLUXCAL_REQUIRE_INTERPRETERS) saying why."""
    path = interpreter(name)
    if path is None:
        msg = "%s is not built: make interpreters (python -m desktop.firmware.interpreters build)" % name
        if os.environ.get("FLUXCAL_REQUIRE_INTERPRETERS"):
            pytest.fail(msg)
        pytest.skip(msg)
    return path


def float_eps(name):
    """Relative rounding unit (half an ulp) of the float type the interpreter computes in."""
    return 2.0 ** -FLOAT_BITS[name]


def heap_bytes(name):
    """The heap (bytes) a simulated board's interpreter runs with (desktop.devicesim.runners.heap_for)."""
    from desktop.devicesim.runners import heap_for

    size = heap_for(name).upper()
    return int(size[:-1]) * 1024 if size.endswith("K") else int(size)
