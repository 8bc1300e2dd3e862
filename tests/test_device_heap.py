"""A session's modules leave with it (device/calibration_flow.py), and come back unchanged.

The firmware imports session.py, the gates, the fit and its solver when a calibration starts and
drops them from sys.modules when it ends, so that idle and survey run without their bytecode
(docs/firmware.md, the heap). tests/micropython/two_sessions.py boots the App on the bench's
loop-back board (.mpy image, real frames of a hand rotation from a file) and runs two full
calibrations on the same frames, once as a board does and once with the modules imported before
boot, which the flow then leaves in place. The calibrations must be the same to the bit in every
case: the second session runs on modules imported afresh, the first as the only one.
"""

import ast
import json
import os
import re
import shutil
import subprocess

import pytest

from desktop.bench.device import SCRIPTS, frame_table
from desktop.firmware.image import build_image
from tests.interpreters import INTERPRETERS, need

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "two_sessions.py")
INTERNED = os.path.join(REPO, "tests", "micropython", "interned.py")


@pytest.fixture(scope="module")
def bench_folder(tmp_path_factory):
    """The .mpy image (lib), the sources (lib-py: CircuitPython refuses MicroPython's .mpy), loopboard.py,
    the script and 10 s of frames at 1000 SPS; -> (folder, nT per code)."""
    tmp = str(tmp_path_factory.mktemp("two-sessions"))
    build_image(os.path.join(tmp, "lib"), runtime="sim")
    build_image(os.path.join(tmp, "lib-py"), runtime="sim", compiled=False)
    shutil.copy(os.path.join(SCRIPTS, "loopboard.py"), tmp)
    shutil.copy(SCRIPT, tmp)
    shutil.copy(INTERNED, tmp)
    table, scale = frame_table(rate=1000)
    with open(os.path.join(tmp, "frames.bin"), "wb") as f:
        f.write(table)
    return tmp, scale


def _run(name, exe, folder, scale, resident):
    root = "flash-%s-%d" % (name, resident)   # an empty flash for each run
    os.mkdir(os.path.join(folder, root))
    r = subprocess.run([exe, "-X", "heapsize=512K", "two_sessions.py", "frames.bin", root, repr(scale),
                        "1" if resident else "0"], capture_output=True, text=True, timeout=900, cwd=folder,
                       env=dict(os.environ, MICROPYPATH="lib-py" if name == "circuitpython" else "lib"))
    assert r.returncode == 0, (r.stdout + r.stderr)[-2000:]
    return json.loads(r.stdout.splitlines()[-1])


@pytest.mark.parametrize("name", INTERPRETERS)
def test_session_modules_leave_and_return_the_same(name, micropython, bench_folder):
    exe = micropython if name == "micropython" else need(name)
    folder, scale = bench_folder
    dropped = _run(name, exe, folder, scale, False)
    kept = _run(name, exe, folder, scale, True)
    assert dropped["cals"][0]["meta"]["kind"] == "full", dropped["cals"][0]    # a calibration, not a failure
    assert dropped["loaded"] == [[], []]
    assert kept["loaded"] == [["session", "gates", "acceptance", "shared.fit", "shared.solver"]] * 2
    # the heap they held is given back: dropped leaves less in use after each finish
    assert all(d < k for d, k in zip(dropped["heap"], kept["heap"])), (dropped["heap"], kept["heap"])
    assert dropped["cals"] == kept["cals"]
    assert dropped["cals"][1] == dropped["cals"][0]


def test_nothing_holds_an_ended_session(tmp_path):
    """Once a calibration ends, nothing the firmware keeps refers to its session, its gates or its fit:
    held (as the de-lag's on_hole held the gates' bound break_chain), they and the bytecode of the
    modules the flow drops would stay on the heap into the next session (a second calibration then
    needed 256 KB of a 32-bit heap, not 210)."""
    import gc
    import weakref

    from tests.device_session import ask, boot

    w, dev = boot(tmp_path, motion="hand", seconds=20.0)
    ask(w, dev, "start-cal full hold")
    dev.run_until(w.time + 3.0)
    s = dev.app.flow.session
    held = [weakref.ref(s), weakref.ref(s.gates), weakref.ref(s.fit)]
    s = None
    for missing in (1, 3):              # blocks lost (acq.poll's on_gap): a polled board's usual
        dev.app._gap_cb(missing)        # one, bridged where it can be, and a longer one
    dev.run_until(w.time + 1.0)
    ask(w, dev, "finish-cal", dt=2.0)
    dev.run_until(w.time + 1.0)
    gc.collect()
    assert dev.app.flow.session is None
    assert [r() for r in held] == [None] * 3, [gc.get_referrers(r()) for r in held if r() is not None]
    dev.close()


def _later_imports():
    """The firmware modules device/ and shared/ import inside a function (after boot), by their source."""
    ours = {f[:-3] for f in os.listdir(os.path.join(REPO, "device")) if f.endswith(".py")}
    ours |= {"shared." + f[:-3] for f in os.listdir(os.path.join(REPO, "shared")) if f.endswith(".py")}
    found = set()
    for folder in ("device", "shared"):
        for f in sorted(os.listdir(os.path.join(REPO, folder))):
            if f.endswith(".py"):
                with open(os.path.join(REPO, folder, f)) as src:
                    tree = ast.parse(src.read())
                for fn in (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)):
                    for n in ast.walk(fn):
                        if isinstance(n, ast.Import):
                            found |= {a.name for a in n.names} & ours
                        elif isinstance(n, ast.ImportFrom):
                            found |= ({n.module} | {n.module + "." + a.name for a in n.names}) & ours
    return sorted(found)


@pytest.mark.parametrize("name", INTERPRETERS)
def test_no_import_after_boot_interns_a_name(name, micropython, bench_folder):
    """MicroPython's qstr pools never shrink and each new one is twice the last: the firmware's names
    sit at the edge of a pool, and the next one takes ~9 KB in one block, which a heap a session has
    fragmented could not give (finishes refused no_memory on the emulated Pico). device/firmware_names.py,
    imported first at boot (device/session_modules.py intern_names), interns every name the firmware's
    .mpy files hold: no module imported after boot (found in the sources) interns a name, and none of
    them stays resident."""
    exe = micropython if name == "micropython" else need(name)
    folder, scale = bench_folder
    later = _later_imports()
    assert {"session", "shared.tempco", "residual_stats", "shared.quick"} <= set(later), later  # the scan works
    root = "flash-interned-%s" % name
    os.mkdir(os.path.join(folder, root))
    r = subprocess.run([exe, "-X", "heapsize=512K", "interned.py", "frames.bin", root, repr(scale)] + later,
                       capture_output=True, text=True, timeout=300, cwd=folder,
                       env=dict(os.environ, MICROPYPATH="lib-py" if name == "circuitpython" else "lib"))
    assert r.returncode == 0, (r.stdout + r.stderr)[-2000:]
    out = r.stdout
    pools = [re.search(r"n_pool=(\d+), n_qstr=(\d+)", part).groups() for part in out.split("later:")]
    assert pools[0][0] == pools[1][0], out      # no new pool, the block that was refused
    if name != "circuitpython":   # .mpy: not a name more. CircuitPython compiles the sources (lib-py),
        assert pools[0] == pools[1], out   # whose local names its parser interns as well: only the pool
    resident = out.split("resident:")[1].split()   # a session's and a finish's modules were dropped again
    assert not {"session", "shared.fit", "shared.tempco", "residual_stats"} & set(resident), resident
