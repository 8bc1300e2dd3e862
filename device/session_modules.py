"""The modules a calibration session imports and drops, and the firmware's names interned at boot.

    intern_names()              # app.py, before its own imports: every name the firmware interns, at once
    path = sums_path()          # "native" or "python": the session's native modules, resident from here
    resident = set(sys.modules)
    ...                         # a session imports its modules
    drop_modules(resident)      # and they go when it ends (their bytecode is freed)

A session's modules (~42 KB of a 32-bit heap as .mpy) go when it ends, so idle and survey run without
their bytecode (docs/firmware.md); not on CPython, whose sys.modules the host's code shares.

Why intern_names: MicroPython keeps every name (qstr) it interns, in pools that never shrink, and each
new pool is twice the last (py/qstr.c, qstr_add_). The `.mpy` firmware's names run past the end of a
640-entry pool: one name takes a pool of 1,280 entries, 7-9 KB in one block. Where that name came with
a module imported late (shared.tempco at the first finish with a calibration to replace,
residual_stats), the block had to come from a heap the session had split, and the finish was refused
no_memory "allocating 1280 bytes" (m_malloc_fail is given the pool's entries); and each module's names,
interned as it loaded, left their 128-byte blocks among its bytecode, holes in the heap once it was
dropped. firmware_names.py (generated: desktop/firmware/names.py) holds every name the firmware's
modules intern: imported first, into an empty heap, it interns them side by side and the pool finds its
block; then no module interns a name. A frozen image's names are in its flash.
"""

import sys

_UNLOAD = sys.implementation.name != "cpython"
_NAMES = "firmware_names"


def sums_path():
    """Which sums the fit runs, "native" or "python" (`status`); the session's native modules, resident from here."""
    for name in ("gatesc", "fitsums"):      # fitsums last: shared/fit.py's test, its import says the path
        try:
            path = __import__(name) and "native"
        except (ImportError, ValueError):   # ValueError: a .mpy of another arch or version
            path = "python"
    return path


def drop_modules(resident):
    """Drop the modules not in `resident` from sys.modules, and from their package: their bytecode
    is freed once nothing refers to them; the next import loads them again."""
    if not _UNLOAD or resident is None:
        return
    for name in [m for m in sys.modules if m not in resident]:
        del sys.modules[name]
        dot = name.rfind(".")
        if dot > 0 and name[:dot] in sys.modules:
            try:
                delattr(sys.modules[name[:dot]], name[dot + 1:])
            except AttributeError:
                pass


def intern_names():
    """firmware_names imported, and dropped: every name the firmware interns, interned (module docstring)."""
    if not _UNLOAD:
        return
    resident = set(sys.modules)
    import firmware_names as names
    # an import interns the file it loaded too (the module's __file__): the firmware's, as this board
    # names them ("/lib/session.mpy"); not where the modules are frozen (their names in flash)
    path = getattr(names, "__file__", "")
    at = path.find(_NAMES + ".")
    if at >= 0 and not path.startswith(".frozen"):
        head, tail = path[:at], path[at + len(_NAMES):]   # "/lib/", ".mpy"
        for m in names.MODULES:
            getattr(names, head + m + tail, None)
    drop_modules(resident)
