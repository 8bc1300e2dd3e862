"""How the wheel is laid out: one top-level package, fluxcal (docs/install.md).

The repository keeps the design's folders, desktop/, shared/ and device/, whose
modules import each other by those names (`from shared import linalg`, as on a
board). A wheel that put those names into site-packages would break, or be
broken by, any other package called desktop or shared, so the wheel holds one:

    fluxcal/__init__.py         the version
    fluxcal/desktop/...         desktop/, its imports of desktop and shared now of fluxcal.desktop, fluxcal.shared
    fluxcal/shared/...          shared/, the same: the laptop's copy of the core
    fluxcal/board/device/...    device/ untouched: what `fluxcal deploy` and `fluxcal emulate` put on a board
    fluxcal/board/shared/...    shared/ untouched: the core as a board imports it

The imports are rewritten with tokenize, in import statements only (`from
desktop.x import y`; a plain `import desktop.x` would bind another name, so the
build refuses it). Folders without __init__.py under desktop/ (the stand-ins of
a board's C modules, the scripts run inside micropython, the emulated Pico's
node files) are data, copied as they are.

`pip install -e .` (the Makefile's) keeps the source tree's names: desktop,
shared and device are found in the checkout, and fluxcal.desktop.cli (the
command's entry point) is desktop/cli found under the name the wheel gives it.
"""

import io
import os
import sys
import tokenize
import warnings

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py
from setuptools.warnings import InformationOnly

HERE = os.path.dirname(os.path.abspath(__file__))
LAPTOP = ("desktop", "shared")          # the laptop's packages, renamed fluxcal.NAME
BOARD = ("device", "shared")            # what a board gets, shipped untouched under fluxcal/board/
SKIP = ("__pycache__", "node_modules", ".pytest_cache")
INIT = '''"""fluxcal: in-field scalar calibration of a three-axis fluxgate magnetometer.

fluxcal.desktop: the laptop's tools (the `fluxcal` command); fluxcal.shared: the calibration
core; fluxcal/board/: the firmware's files as a board gets them (fluxcal deploy, emulate).
"""

__version__ = %r
'''


class ImportRewriteError(Exception):
    pass


def rewrite_imports(text, path):
    """text with `from NAME...` of the laptop's packages now `from fluxcal.NAME...`.

    from and import are keywords: a `from` followed by a dotted name and `import` starts an
    import statement (`yield from x` and `raise e from x` are not followed by import); an
    `import` that does not end such a `from` starts one too.
    """
    lines = text.splitlines(keepends=True)
    tokens = [t for t in tokenize.generate_tokens(io.StringIO(text).readline)
              if t.type not in (tokenize.NL, tokenize.COMMENT)]
    edits = []      # (row, col) where "fluxcal." goes
    k = 0
    while k < len(tokens):
        tok = tokens[k]
        k += 1
        if tok.type != tokenize.NAME or tok.string not in ("from", "import"):
            continue
        first = tokens[k]
        if tok.string == "from":
            j = k
            while tokens[j].string != "import" and (tokens[j].type == tokenize.NAME
                                                    or tokens[j].string in (".", "...")):   # relative levels
                j += 1
            if tokens[j].string != "import":
                continue            # yield from / raise ... from
            k = j + 1               # past this statement's import
        if tok.string == "import":      # every name of `import a, b.c as d`
            j = k
            while tokens[j].type != tokenize.NEWLINE and tokens[j].string != ";":
                if tokens[j].string in LAPTOP + ("device",) and tokens[j - 1].string in ("import", ","):
                    first = tokens[j]
                    break
                j += 1
        if first.type == tokenize.NAME and first.string in LAPTOP + ("device",):
            if first.string == "device":
                raise ImportRewriteError("%s:%d: the laptop reaches the firmware through import_device(), not"
                                         " `%s device`" % (path, tok.start[0], tok.string))
            if tok.string == "import":
                raise ImportRewriteError("%s:%d: `import %s` cannot be renamed for the wheel (it would bind"
                                         " another name): from %s... import" % (path, tok.start[0], first.string,
                                                                                first.string))
            edits.append(first.start)
    for row, col in reversed(edits):
        line = lines[row - 1]
        lines[row - 1] = line[:col] + "fluxcal." + line[col:]
    return "".join(lines)


def _files(top):
    for folder, dirs, names in os.walk(top):
        dirs[:] = sorted(d for d in dirs if d not in SKIP)
        for name in sorted(names):
            if not name.endswith((".pyc", ".pyo")):
                yield os.path.join(folder, name)


def _is_module(path, top):
    """A .py file of a package (every folder from top down has __init__.py), not a data file."""
    if not path.endswith(".py"):
        return False
    folder = os.path.dirname(path)
    while True:
        if not os.path.isfile(os.path.join(folder, "__init__.py")):
            return False
        if os.path.samefile(folder, top):
            return True
        folder = os.path.dirname(folder)


class BuildFluxcal(build_py):
    """The wheel's fluxcal/ tree (module docstring); an editable install builds as setuptools does."""

    def run(self):
        if getattr(self, "editable_mode", False):
            return super().run()
        for src, dst, rewrite in self._plan():
            os.makedirs(os.path.dirname(dst), exist_ok=True)
            if src is None:
                with open(dst, "w", encoding="utf-8") as fh:
                    fh.write(INIT % self.distribution.get_version())
            elif rewrite:
                with open(src, encoding="utf-8") as fh:
                    text = rewrite_imports(fh.read(), os.path.relpath(src, HERE))
                with open(dst, "w", encoding="utf-8") as fh:
                    fh.write(text)
            else:
                self.copy_file(src, dst, preserve_mode=False)

    def _plan(self):
        """(source or None for the generated __init__, destination, rewrite its imports?)"""
        out = os.path.join(self.build_lib, "fluxcal")
        yield None, os.path.join(out, "__init__.py"), False
        for name in LAPTOP:
            top = os.path.join(HERE, name)
            for src in _files(top):
                yield src, os.path.join(out, os.path.relpath(src, HERE)), _is_module(src, top)
        for name in BOARD:
            for src in _files(os.path.join(HERE, name)):
                yield src, os.path.join(out, "board", os.path.relpath(src, HERE)), False

    def get_outputs(self, include_bytecode=True):
        if getattr(self, "editable_mode", False):
            return super().get_outputs(include_bytecode)
        return [dst for _src, dst, _rewrite in self._plan()]


class WheelDistribution(Distribution):
    """build_py runs although no package is declared: BuildFluxcal makes them."""

    def has_pure_modules(self):
        return True


def main():
    if "editable_wheel" in sys.argv:
        # an editable install (pip install -e .): the source tree's names, and fluxcal a namespace
        # over the checkout, so that the entry point fluxcal.desktop.cli is desktop/cli (whose own
        # imports then load desktop.*, as in the tree). setuptools' notice on such installs warns
        # of a folder in the working directory named as the package: the checkout has none
        # (fluxcal/ exists in the wheel only), so `make demo` and `make test` do not print it.
        warnings.filterwarnings("ignore", category=InformationOnly)
        setup(packages=["desktop", "shared", "device", "fluxcal"], package_dir={"fluxcal": "."})
    else:
        setup(packages=[], distclass=WheelDistribution, cmdclass={"build_py": BuildFluxcal})


if __name__ == "__main__":     # as setuptools runs it; imported, it only defines (tests/test_wheel_layout.py)
    main()
