"""The calibration core on the emulated Raspberry Pi Pico, with and without the fit's native sums.

    python -m desktop.bench.pico_core       # about 3-5 wall min on a 2-core machine

What: micropython-scripts/cortexm_core.py (EllipsoidFit.add() with the collector off and
with the collections it causes, the bytes it leaves, solve() of a 1300-sample distorted
sphere, a provisional solve of it, a quick re-calibration) run on the rp2 port's firmware in the
RP2040 emulator (desktop/devicesim/pico_board.py), shared/ and the script as .mpy from the Pico's
own mpy-cross, copied into its flash by mpremote: once without a native module (pure Python),
once with fitsums.mpy for armv6m beside them (desktop/firmware/natmod.py: the native sums) and
once with linalgc.mpy too (the solver's float kernels, shared/linalg.py's in C), as deploy
installs them. The Pico's
clock is emulated at 125 MHz and advances per instruction cycle, so a ticks_us difference
is emulated time: x 125 gives cycles. Deterministic up to where the collections fall.
"""

import json
import os
import subprocess
import sys
import tempfile

from desktop.devicesim.pico_board import PicoBoard
from desktop.firmware.files import REPO
from desktop.firmware.interpreters import pico_parts
from desktop.firmware.natmod import natmod_path

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts", "cortexm_core.py")
MHZ = 125
ROWS = [("add_no_gc", "EllipsoidFit.add(), garbage collection off"),
        ("add", "EllipsoidFit.add(), collections included (1300 calls)"),
        ("solve", "EllipsoidFit.solve() (1300-sample sphere)"),
        ("solve_provisional", "provisional solve of the same sums (max_iter=1, every solve_every_s while calibrating)"),
        ("solve_quick", "quick re-calibration solve(prior=...) of the same sums")]


def _disk(folder, native, script=SCRIPT, linalg=None):
    """shared/ and the script (and cortexm_core, which others import) as .mpy for the Pico;
    fitsums.mpy too when `native`, linalgc.mpy when `linalg` (their paths)."""
    cross = pico_parts()["mpy_cross"]
    os.makedirs(os.path.join(folder, "shared"))
    for name in sorted(os.listdir(os.path.join(REPO, "shared"))):
        if name.endswith(".py"):
            subprocess.run([cross, "-o", os.path.join(folder, "shared", name[:-3] + ".mpy"),
                            os.path.join(REPO, "shared", name)], check=True)
    for path in sorted({SCRIPT, script}):
        name = os.path.splitext(os.path.basename(path))[0]
        subprocess.run([cross, "-o", os.path.join(folder, name + ".mpy"), path], check=True)
    for path, name in ((native, "fitsums.mpy"), (linalg, "linalgc.mpy")):
        if path:
            with open(path, "rb") as src, open(os.path.join(folder, name), "wb") as dst:
                dst.write(src.read())


def run(native, script=SCRIPT, linalg=None):
    """The script's figures (cortexm_core's by default: its main() prints one JSON line) on the
    emulated Pico (ns of emulated time), and which sums ran ("+linalg": and the float kernels)."""
    name = os.path.splitext(os.path.basename(script))[0]
    with tempfile.TemporaryDirectory(prefix="fluxcal-pico-core-") as tmp:
        disk = os.path.join(tmp, "disk")
        _disk(disk, native, script, linalg)
        code = ("import sys; sys.path.insert(0, '/disk')\ntry:\n import linalgc\nexcept ImportError:\n pass\n"
                "from shared import fit, linalg_native; "
                "print('sums', fit.SUMS_PATH + ('+linalg' if linalg_native.install() else '')); "
                "import %s; %s.main()" % (name, name))
        with PicoBoard(os.path.join(tmp, "pico.flash")) as board:
            r = subprocess.run([sys.executable, "-m", "mpremote", "connect", board.port, "cp", "-r", disk, ":",
                                "+", "exec", code], capture_output=True, text=True, timeout=1800)
    if r.returncode:
        raise RuntimeError("the Pico run failed: %s" % (r.stdout + r.stderr).strip()[-500:])
    lines = r.stdout.splitlines()
    path = next(ln.split()[1] for ln in lines if ln.startswith("sums "))
    return path, json.loads(lines[-1])


def _cell(ns):
    us = ns / 1000.0
    return "%.1f us, %s cycles" % (us, "{:,}".format(round(us * MHZ)))


def main(argv=None):
    native, linalg = natmod_path("armv6m"), natmod_path("armv6m", "linalgc")
    if native is None or linalg is None:
        print("no fitsums.mpy or linalgc.mpy for armv6m: make interpreters", file=sys.stderr)
        return 1
    got = {}
    for which, kernels in ((None, None), (native, None), (native, linalg)):
        path, figures = run(which, linalg=kernels)
        got[path] = figures
    paths = ("python", "native", "native+linalg")
    print("| path (emulated Pico, 125 MHz) | pure Python (packed big integers) | native sums (fitsums.mpy) "
          "| native sums and float kernels (+ linalgc.mpy) |")
    print("|---|---|---|---|")
    for key, label in ROWS:
        print("| %s | %s |" % (label, " | ".join(_cell(got[p][key]) for p in paths)))
    print("| bytes left per add(), collector off | %s |" % " | ".join(str(got[p]["add_bytes"]) for p in paths))
    print("| solve iterations | %s |" % " | ".join(str(got[p]["iterations"]) for p in paths))
    return 0


if __name__ == "__main__":
    sys.exit(main())
