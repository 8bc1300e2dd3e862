"""Which files make the firmware of each runtime, read from device/manifest.py.

    from desktop.firmware.files import firmware_files, root_files, package_json
    firmware_files("micropython")   # [(source path, path under /lib), ...]
    root_files("circuitpython")     # [(source path, name at the filesystem root), ...]
    package_json()                  # what device/package.json must hold
    import_device("store")          # a firmware module, imported into this CPython

The manifest is MicroPython's freezing format; it is run here as the freezing
tool runs it (tools/manifestfile.py in MicroPython's source), with stand-ins
for metadata(), include(), module() and package() that record the files, and
options.runtime set to the runtime asked for.

    python -m desktop.firmware.files > device/package.json    # regenerate it
"""

import importlib
import json
import os
import sys

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# The firmware's files as a board gets them: device/ and shared/ of the checkout; in an installed
# wheel (REPO is then site-packages/fluxcal) fluxcal/board/, whose shared/ still imports itself
# as `shared` (the wheel's fluxcal/shared is the laptop's copy, renamed: setup.py)
BOARD = os.path.join(REPO, "board") if os.path.isdir(os.path.join(REPO, "board", "device")) else REPO
DEVICE = os.path.join(BOARD, "device")
SIM = os.path.join(DEVICE, "sim")   # the simulated board's firmware files (flat on its image, as all are)
MANIFEST = os.path.join(DEVICE, "manifest.py")
PACKAGE_JSON = os.path.join(DEVICE, "package.json")
RUNTIMES = ("micropython", "circuitpython", "sim")


class _Options:
    """options in a manifest: keyword arguments, else the manifest's own defaults."""

    def __init__(self, **kwargs):
        self._kwargs = kwargs
        self._defaults = {}

    def defaults(self, **kwargs):
        self._defaults = kwargs

    def __getattr__(self, name):
        return self._kwargs.get(name, self._defaults.get(name))


class ManifestError(Exception):
    pass


def read_manifest(runtime="micropython"):
    """(version, [(source, target)], root files) of one runtime, in manifest order."""
    if runtime not in RUNTIMES:
        raise ManifestError("unknown runtime %r (one of %s)" % (runtime, ", ".join(RUNTIMES)))
    collected, meta = [], {}

    def metadata(**kw):
        meta.update(kw)

    def include(path, **kw):
        if not path.startswith("$(PORT_DIR)"):   # the port's own manifest: a freeze build's business
            raise ManifestError("include(%r): only the port's manifest may be included" % path)

    def module(path, base_path=".", opt=None):
        src = os.path.normpath(os.path.join(DEVICE, base_path, path))
        if not os.path.isfile(src):
            raise ManifestError("module(%r): no file %s" % (path, src))
        collected.append((src, path))

    def package(name, files=None, base_path=".", opt=None):
        top = os.path.normpath(os.path.join(DEVICE, base_path, name))
        if files is None:   # the whole package, as the freezing tool takes it
            files = sorted(os.path.relpath(os.path.join(folder, n), top) for folder, _dirs, names in os.walk(top)
                           for n in names if n.endswith(".py"))
        if not files:
            raise ManifestError("package(%r): no .py files in %s" % (name, top))
        for rel in files:
            collected.append((os.path.join(top, rel), (name + "/" + rel).replace(os.sep, "/")))

    scope = {"options": _Options(runtime=runtime), "metadata": metadata, "include": include,
             "module": module, "package": package, "require": _refuse, "freeze": _refuse}
    with open(MANIFEST) as fh:
        exec(compile(fh.read(), MANIFEST, "exec"), scope)
    roots = [(os.path.join(DEVICE, name), name) if isinstance(name, str) else (os.path.join(DEVICE, name[0]), name[1])
             for name in scope.get("ROOT_FILES", {}).get(runtime, ())]
    return meta.get("version"), collected, roots


def _refuse(*args, **kwargs):
    raise ManifestError("the firmware needs nothing from micropython-lib or frozen elsewhere")


def firmware_files(runtime="micropython"):
    """[(source path, path under /lib)] of the runtime's firmware."""
    return read_manifest(runtime)[1]


def root_files(runtime="micropython"):
    """[(source path, name at the filesystem root)]: the runtime's entry points."""
    return read_manifest(runtime)[2]


def package_json():
    """device/package.json for `mpremote mip install ./device/package.json` (MicroPython boards)."""
    version, files, _ = read_manifest("micropython")
    urls = [[target, os.path.relpath(src, DEVICE).replace(os.sep, "/")] for src, target in files]
    return {"urls": urls, "version": version}


def package_json_text():
    """package.json as committed: one [target, source] pair per line."""
    d = package_json()
    urls = ",\n".join("    " + json.dumps(u) for u in d["urls"])
    return '{\n  "urls": [\n%s\n  ],\n  "version": %s\n}\n' % (urls, json.dumps(d["version"]))


def import_device(name):
    """A firmware module (device/NAME.py, device/sim/NAME.py) imported into this CPython process.

    The firmware's modules import each other flat (`import app`), as on a
    board, so device/ and device/sim/ go on sys.path, and their parent for `shared`.
    """
    for path in (BOARD, SIM, DEVICE):
        if path not in sys.path:
            sys.path.insert(0, path)
    return importlib.import_module(name)


if __name__ == "__main__":
    sys.stdout.write(package_json_text())
