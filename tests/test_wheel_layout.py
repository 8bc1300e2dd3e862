"""setup.py's renaming of the laptop's imports for the wheel, on every module it will rename.

Fast, without building a wheel (tests/test_deploy_wheel.py builds and installs one): each module
of the desktop/ and shared/ packages renamed as the wheel gets it still parses, imports nothing
top-level called desktop, shared or device, and differs from the source only in `fluxcal.`
inserted after `from`; an import the renaming cannot carry over (`import shared.x`, which binds
another name) is refused with the file and line.
"""

import ast
import importlib.util
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_spec = importlib.util.spec_from_file_location("fluxcal_setup", os.path.join(ROOT, "setup.py"))
setup = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(setup)     # defines only: setup() runs when setuptools runs the file


def _laptop_modules():
    for name in setup.LAPTOP:
        top = os.path.join(ROOT, name)
        for path in setup._files(top):
            if setup._is_module(path, top):
                yield os.path.relpath(path, ROOT)


def _top_imports(tree):
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            yield node.module.split(".")[0]


def test_every_laptop_module_is_renamed_into_fluxcal():
    modules = list(_laptop_modules())
    assert "desktop/cli/__init__.py" in modules and "shared/fit.py" in modules
    assert not any("stand-ins" in m or "micropython-scripts" in m or "on-board" in m for m in modules)
    renamed = 0
    for rel in modules:
        with open(os.path.join(ROOT, rel), encoding="utf-8") as fh:
            text = fh.read()
        out = setup.rewrite_imports(text, rel)
        assert not {"desktop", "shared", "device"} & set(_top_imports(ast.parse(out, rel))), rel
        assert out.replace("fluxcal.", "") == text.replace("fluxcal.", ""), rel     # nothing else touched
        renamed += out != text
    assert renamed > len(modules) // 2      # most modules import the core or each other


@pytest.mark.parametrize("text, want", [
    ("from shared import linalg\n", "from fluxcal.shared import linalg\n"),
    ("def f():\n    from desktop.cli._errors import (CommandError,\n        x)\n",
     "def f():\n    from fluxcal.desktop.cli._errors import (CommandError,\n        x)\n"),
    ("s = 'from shared import x'  # from desktop import y\n", "s = 'from shared import x'  # from desktop import y\n"),
    ("from sharedx import a\nfrom . import shared\nfrom ...x import shared\n",
     "from sharedx import a\nfrom . import shared\nfrom ...x import shared\n"),
    ("def g():\n    yield from shared_items()\n", "def g():\n    yield from shared_items()\n"),
])
def test_only_import_statements_of_the_laptop_packages_change(text, want):
    assert setup.rewrite_imports(text, "x.py") == want


@pytest.mark.parametrize("text", ["import shared.codes\n", "import os, desktop.cli\n", "from device import app\n"])
def test_an_import_the_renaming_cannot_carry_over_is_refused(text):
    with pytest.raises(setup.ImportRewriteError, match="x.py:1"):
        setup.rewrite_imports(text, "x.py")
