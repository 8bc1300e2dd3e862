"""The house's rules: what each folder may import (the README's Layout table), read from the code.

A folder's modules may import the standard library, the third-party packages
named for it, and the project folders listed beside it; nothing else. So a
reader knows from a file's path what it can touch, and an import that crosses
a rule (the simulator reaching into the firmware runner, a file format into
the simulator's engine, shared/ into numpy) fails here.
"""

import ast
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

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
    "desktop/demo": (("numpy", "matplotlib"), ("desktop.sim", "desktop.methods", "desktop.devicesim",
                                               "desktop.firmware", CODES)),
    "desktop/bench": (("numpy", "serial"), ("shared", "desktop.sim", "desktop.methods", "desktop.devicesim",
                                             "desktop.firmware", "desktop.formats", "desktop.link")),
    "desktop/link": (("serial",), (CODES,)),
    "desktop/cli": (("numpy", "matplotlib", "rich"), ("shared", "desktop")),
}
# the MicroPython-only modules shared/ guards with try/except ImportError
MICROPYTHON_ONLY = {"micropython"}


def _modules(folder):
    for d, _, files in os.walk(os.path.join(ROOT, folder)):
        if {"micropython-scripts", "stand-ins"} & set(os.path.relpath(d, ROOT).split(os.sep)):
            continue   # run inside micropython / CircuitPython, not modules of the desktop package
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
                if top not in ("math", "array") and top not in MICROPYTHON_ONLY:
                    bad.append("%s imports %s (shared/ runs on MicroPython: math, array)" % (where, name))
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
