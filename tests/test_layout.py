"""The house's rules: what each folder may import (the README's Layout table), read from the code.

A folder's modules may import the standard library, the third-party packages
named for it, and the project folders listed beside it; nothing else. So a
reader knows from a file's path what it can touch, and an import that crosses
a rule (the simulator reaching into the firmware runner, a file format into
the simulator's engine, shared/ into numpy) fails here.

device/ is flat (its modules import each other by name, as on a board), so its
rules are by role: the calibration core (gates, session, acceptance) imports no
protocol, command, app or HAL; only app.py builds the owners of the firmware's
state; only the entry points import a HAL. The desktop reaches the firmware
through import_device("name"), held to a list per folder.
"""

import ast
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# the firmware's native modules, one per device/native/<name>.c
NATIVE_MODULES = sorted(f[:-2] for f in os.listdir(os.path.join(ROOT, "device", "native")) if f.endswith(".c"))

# The names both ends of the serial line agree on: whatever speaks to the firmware may use them.
CODES = "shared.codes"
# folder -> (third-party packages, project packages it may import besides itself)
RULES = {
    "shared": ((), ()),
    "desktop/sim": (("numpy",), ()),
    "desktop/formats": (("numpy",), ("shared", "desktop.sim.ads1292.registers")),
    "desktop/methods": (("numpy",), ("shared",)),
    "desktop/firmware": ((), ()),
    "desktop/devicesim": (("numpy",), ("desktop.sim", "desktop.firmware", CODES)),
    "desktop/experiments": (("numpy", "matplotlib"), ("shared", "desktop.sim", "desktop.methods",
                                                      "desktop.formats")),
    # desktop.methods: the turn-rate check the report's verdict shares with fit's refusal (turn_rate.py)
    "desktop/views": (("numpy", "matplotlib"), ("shared", "desktop.methods")),
    "desktop/survey": (("numpy", "matplotlib"), ("shared", "desktop.formats", "desktop.sim.field")),
    "desktop/demo": (("numpy", "matplotlib"), ("desktop.sim", "desktop.methods", "desktop.devicesim",
                                               "desktop.firmware", "desktop.views", CODES)),
    "desktop/bench": (("numpy", "serial"), ("shared", "desktop.sim", "desktop.methods", "desktop.devicesim", "desktop.survey",
                                             "desktop.firmware", "desktop.formats", "desktop.link")),
    "desktop/link": (("serial", "pynmea2"), (CODES,)),     # pynmea2: the GPS's NMEA (the gps extra)
    "desktop/cli": (("numpy", "matplotlib", "rich"), ("shared", "desktop")),
}
# the MicroPython-only modules shared/ guards with try/except ImportError
# fitsums: the native sums, delagc: the de-lag's push (device/native), where deployed
MICROPYTHON_ONLY = {"micropython", "fitsums", "delagc"}


def _modules(folder):
    for d, _, files in os.walk(os.path.join(ROOT, folder)):
        if {"micropython-scripts", "stand-ins", "on-board"} & set(os.path.relpath(d, ROOT).split(os.sep)):
            continue   # run inside micropython / CircuitPython (on a board), not modules of the desktop package
        for f in files:
            if f.endswith(".py"):
                yield os.path.join(d, f)


def _imports(path):
    tree = ast.parse(open(path).read(), path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            # each name: `from shared import codes` is an import of shared.codes, not of all of shared
            yield from (node.module + "." + a.name for a in node.names)


def _own(folder):
    return folder.replace("/", ".")


@pytest.mark.parametrize("folder", sorted(RULES))
def test_folder_imports_only_what_its_rule_allows(folder):
    third, project = RULES[folder]
    allowed = (_own(folder),) + project
    bad = []
    for path in _modules(folder):
        where = os.path.relpath(path, ROOT)
        for name in _imports(path):
            top = name.split(".")[0]
            if top in ("shared", "desktop", "device", "tests"):
                if not any(name == p or name.startswith(p + ".") for p in allowed):
                    bad.append("%s imports %s" % (where, name))
            elif folder == "shared":
                # sys: its modules dict, on every port (shared/linalg.py looks for the firmware's float kernels)
                if top not in ("math", "array", "sys") and top not in MICROPYTHON_ONLY:
                    bad.append("%s imports %s (shared/ runs on MicroPython: math, array, sys)" % (where, name))
            elif top not in sys.stdlib_module_names and top not in third:
                bad.append("%s imports %s" % (where, name))
    assert not bad, "\n".join(bad)


def test_every_desktop_folder_has_a_rule():
    folders = {os.path.join("desktop", d) for d in os.listdir(os.path.join(ROOT, "desktop"))
               if os.path.isdir(os.path.join(ROOT, "desktop", d)) and not d.startswith("__")}
    assert folders <= set(RULES), "no import rule for %s (tests/test_layout.py, README Layout)" % (
        folders - set(RULES))


def test_readme_layout_names_every_folder():
    readme = open(os.path.join(ROOT, "README.md")).read()
    table = readme[readme.index("## Layout"):readme.index("## ", readme.index("## Layout") + 3)]
    for folder in list(RULES) + ["device", "tests"]:
        assert "`%s/`" % folder in table, "README's Layout table lacks %s/" % folder


# ****** device/: the firmware's roles ******
DEVICE = os.path.join(ROOT, "device")
# desktop folder -> the firmware modules it may import through import_device() (desktop/firmware/files.py
# puts device/ and device/sim/ on sys.path): none for a folder not named
DEVICE_MODULES = {
    "desktop/devicesim": {"app", "config", "hal_sim", "sim_wire", "store"},
    "desktop/bench": {"commands", "config", "protocol", "sim_wire", "store"},
}
ENTRY_POINTS = {"main", "code", "sim_main", "boot_micropython"}   # boot a board: the only importers of a HAL
# the calibration core: samples, fit, acceptance; it imports no protocol, command, app or HAL
CORE = {"gates", "residuals", "residual_stats", "session", "lagfit", "acceptance"}
# the owners of the firmware's state, by module: only app.py builds them (an entry point the App)
OWNERS = {"acquisition": "Acquisition", "health": "AdcSupervisor", "survey": "Output",
          "calibration_flow": "CalibrationFlow", "bootguard": "Guard", "protocol": "Protocol", "button": "Button",
          "led": "Led", "app": "App"}


def _firmware():
    """{module name: path} of every firmware file: device/ and device/sim/ (flat on a board)."""
    out = {}
    for d in (DEVICE, os.path.join(DEVICE, "sim")):
        for f in sorted(os.listdir(d)):
            if f.endswith(".py") and f != "manifest.py":
                out[f[:-3]] = os.path.join(d, f)
    return out


def _uses(path):
    """(module, name) of every import of a file (`import m`: (m, None); `from m import a`: (m, a)) and of
    every attribute read off an imported module (`m.a`: (m, a))."""
    tree = ast.parse(open(path).read(), path)
    modules = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                modules[a.asname or a.name] = a.name
                yield a.name, None
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            for a in node.names:
                yield node.module, a.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in modules:
            yield modules[node.value.id], node.attr


def test_the_calibration_core_imports_only_shared_and_itself():
    """gates, session, lagfit and acceptance run as they are on the desktop and set-cal: no protocol,
    commands, app, flow, output or HAL reaches into them (their own C, device/native/, and
    micropython.const may)."""
    bad = ["device/%s.py imports %s" % (m, mod) for m in sorted(CORE) for mod, _ in _uses(_firmware()[m])
           if mod.split(".")[0] not in CORE | set(NATIVE_MODULES) | {"shared", "math", "array", "micropython"}]
    assert not bad, "\n".join(bad)


def test_only_app_wires_the_owners():
    """The owners of the firmware's state are built in one place (app.py): any other module gets
    the owner it needs handed to it, so a reader finds who talks to whom there."""
    bad = []
    for m, path in _firmware().items():
        if m == "app":
            continue
        for mod, name in _uses(path):
            if name is not None and OWNERS.get(mod) == name and not (m in ENTRY_POINTS and name == "App"):
                bad.append("%s uses %s.%s (only app.py wires the owners)" % (os.path.relpath(path, ROOT), mod, name))
    assert not bad, "\n".join(bad)


def test_only_the_entry_points_import_a_hal():
    """The HAL is the one place that knows the runtime: an entry point picks it, the HALs extend
    hal.Board, and everything else gets the board handed to it."""
    bad = []
    for m, path in _firmware().items():
        for mod, _ in _uses(path):
            top = mod.split(".")[0]
            if top.startswith("hal_") and m not in ENTRY_POINTS or top == "hal" and not m.startswith("hal_"):
                bad.append("%s imports %s" % (os.path.relpath(path, ROOT), mod))
    assert not bad, "\n".join(bad)


def test_shared_never_imports_the_firmware():
    firmware = set(_firmware()) | {"device"}
    bad = ["%s imports %s" % (os.path.relpath(p, ROOT), mod) for p in _modules("shared") for mod, _ in _uses(p)
           if mod.split(".")[0] in firmware]
    assert not bad, "\n".join(bad)


def _import_device_calls(path):
    tree = ast.parse(open(path).read(), path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) and \
                (getattr(node.func, "id", None) or getattr(node.func, "attr", None)) == "import_device":
            yield node.args[0].value


def test_import_device_follows_the_folder_rules():
    """import_device() imports firmware modules into the desktop: each desktop folder only those
    DEVICE_MODULES lists for it; tests/ any, as long as it is a firmware module."""
    firmware = set(_firmware())
    bad = []
    for folder in sorted(RULES):
        if not folder.startswith("desktop/"):
            continue
        for path in _modules(folder):
            if any(path.startswith(os.path.join(ROOT, f) + os.sep) for f in RULES if len(f) > len(folder)
                   and f.startswith(folder + "/")):
                continue   # a subfolder with its own rule
            for name in _import_device_calls(path):
                if name not in DEVICE_MODULES.get(folder, ()):
                    bad.append("%s: import_device(%r)" % (os.path.relpath(path, ROOT), name))
    for path in _modules("tests"):
        for name in _import_device_calls(path):
            if name not in firmware:
                bad.append("%s: import_device(%r), not a firmware module" % (os.path.relpath(path, ROOT), name))
    assert not bad, "\n".join(bad)


MAX_MODULE_LINES = 400   # STYLE.md: modules of one job, at most 400 lines


@pytest.mark.parametrize("folder", ["shared", "device", "desktop", "tests"])
def test_every_module_is_at_most_400_lines(folder):
    long = []
    for dirpath, _, files in os.walk(os.path.join(ROOT, folder)):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(dirpath, f)
                with open(path, encoding="utf-8") as fh:
                    n = sum(1 for _ in fh)
                if n > MAX_MODULE_LINES:
                    long.append("%s: %d lines" % (os.path.relpath(path, ROOT), n))
    assert not long, "\n".join(long)
