"""The firmware's heap on the emulated Raspberry Pi Pico, beside desktop/bench/heap.py's 32-bit build.

    python -m desktop.bench.heap_pico [--kb 0 100]    # 0: its whole heap; 10-30 wall min a run on 2 cores
    python -m desktop.bench.heap_pico --frozen --kb 100 120     # the image with the firmware frozen in
    python -m desktop.bench.heap_pico --frozen --smallest 80 120   # bisect between two heaps (KB)

What: the same script as heap.py (micropython-scripts/firmware_heap.py: boot, SECONDS calibrating
on the loop-back board reading real frames from a file, the finish, SECONDS in survey with stream
and log on) run from the REPL of the rp2 port's own firmware on the emulated RP2040
(desktop/devicesim/pico_board.py), the firmware as .mpy from the Pico's mpy-cross with
the native modules for armv6m (lib/fitsums.mpy, lib/drdy.mpy), as `fluxcal deploy` installs them.
--frozen: the rp2-pico-frozen image (desktop/firmware/interpreters.py: device/manifest.py frozen
in, its bytecode in flash), the flash holding only the native modules besides the scripts and frames.
How: the Pico's heap is fixed by its build (0 KB asks for its whole heap). A smaller one is
that heap with a ballast bytearray allocated first, so that N KB are left, the REPL's own state
included (as heap.py's figures include the unix interpreter's start-up); the figures below have
the ballast taken out. Each run takes minutes of emulation, so the heaps are the ones asked for,
not bisected (heap.py bisects the 32-bit build), and each runs once.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from desktop.bench.device import DEFAULT, SCRIPTS, _prepare
from desktop.bench.heap import SECONDS, print_table, row
from desktop.devicesim.pico_board import PicoBoard
from desktop.firmware.image import build_image
from desktop.firmware.interpreters import pico_parts
from desktop.firmware.natmod import MODULES, natmod_path

_IMAGE = {False: ".mpy", True: "frozen"}     # the two firmware images, by `frozen`
# the figures firmware_heap.py reports that hold the ballast too
_WITH_BALLAST = ("harness", "boot", "cal", "cal_peak", "survey", "survey_peak", "heap_total")


def _disk(folder, cross, prep, frozen=False):
    """What the Pico's flash gets: lib/ (the firmware's .mpy unless frozen, the native modules), the
    scripts, the frames (heap.py's, made in `prep`); -> (frame file's name, nT per code, whether every
    native module went on)."""
    lib = os.path.join(folder, "lib")
    os.makedirs(lib, exist_ok=True)
    if not frozen:
        build_image(lib, runtime="sim", mpy_cross=cross)
    # every native module deploy installs (desktop/firmware/natmod.py), each where built: the
    # heap holds their code as on a deployed board (drdy.mpy loads even where the loop-back board
    # keeps the Python handler)
    native = True
    for module in MODULES:
        path = natmod_path("armv6m", module)
        native = native and path is not None
        if path is not None:
            shutil.copyfile(path, os.path.join(lib, module + ".mpy"))
    for name in ("firmware_heap.py", "loopboard.py"):
        subprocess.run([cross, "-o", os.path.join(folder, name[:-3] + ".mpy"), os.path.join(SCRIPTS, name)],
                       check=True)
    _lib, frames, scale = _prepare(prep, DEFAULT[0])
    shutil.copyfile(frames, os.path.join(folder, os.path.basename(frames)))
    return os.path.basename(frames), scale, native


def ballast(kb):
    """MicroPython code that leaves `kb` KB of heap (None or 0: all of it) to what runs after it, the
    REPL's state included: a ballast in pieces if no block is that large, kept in the global B; what it
    takes is gc.mem_alloc() - a0, its list included. Run after a reset (no garbage of an earlier step)."""
    return ("import gc\ngc.collect()\na0 = gc.mem_alloc()\n"
            "want = a0 + gc.mem_free() - %d if %d else 0\nB = []\nsize = want\n"
            "while want - (gc.mem_alloc() - a0) > 64:\n"
            "    try:\n        B.append(bytearray(min(size, want - (gc.mem_alloc() - a0)) - 32))\n"
            "    except MemoryError:\n        size = max(64, size // 2)\n") % ((kb or 0) * 1024, kb or 0)


def flash_with(disk, flash, frozen=False):
    """A flash file whose filesystem holds `disk`'s files, copied there once by mpremote (minutes on
    the emulated USB); each run starts from a copy of it (the runner rewrites only the image)."""
    with PicoBoard(flash, idle="jump", frozen=frozen) as board:
        subprocess.run([sys.executable, "-m", "mpremote", "connect", board.port, "cp", "-r", disk + "/.", ":"],
                       check=True, capture_output=True, timeout=7200)
    return flash


def run_pico(template, frames, scale, kb, tmp, track=True, frozen=False):
    """One run of firmware_heap.py on a fresh emulated Pico whose flash is a copy of `template`
    (flash_with), with `kb` KB of heap (None: all of it); track=False collects only when the heap is
    full, as a board does (heap.py's bisection); frozen: on the rp2-pico-frozen image."""
    rate, decim, window = DEFAULT
    args = ["firmware_heap", frames, "fs", str(rate), str(decim), str(window), str(SECONDS), repr(scale),
            "1" if track else "0"]
    code = ("import os, sys\nos.mkdir('/fs')\n" + ballast(kb) + "print('ballast', gc.mem_alloc() - a0, len(B))\n"
            "while sys.argv: sys.argv.pop()\nsys.argv.extend(%r)\nimport firmware_heap\n" % (args,))
    flash = os.path.join(tmp, "pico-%s.flash" % kb)
    shutil.copyfile(template, flash)
    with PicoBoard(flash, idle="jump", frozen=frozen) as board:
        r = subprocess.run([sys.executable, "-m", "mpremote", "connect", board.port, "soft-reset", "+", "exec", code],
                           capture_output=True, text=True, timeout=7200)
    os.remove(flash)
    lines = r.stdout.splitlines()
    taken = [[int(w) for w in ln.split()[1:]] for ln in lines if ln.startswith("ballast ")]
    got = [ln for ln in lines if ln.startswith("{")]
    if r.returncode or not taken or not got:
        if "MemoryError" in r.stdout + r.stderr and taken:   # before the script's own try
            return {"failed": "start"}
        raise RuntimeError("the Pico run at %s KB failed: %s" % (kb, (r.stdout + r.stderr)[-1500:]))
    out = json.loads(got[-1])
    for key in _WITH_BALLAST:
        if out.get(key):
            out[key] -= taken[0][0]
    out["ballast_pieces"] = taken[0][1]
    return out


def smallest(template, frames, scale, tmp, lo, hi, frozen, step=2):
    """The smallest heap (KB, a multiple of `step`) in which boot, calibration and survey succeed,
    bisected between `lo` (which must fail) and `hi` (which must succeed), collecting only when the heap
    is full (heap.py's smallest(), without its check of every size above: each run is minutes here);
    -> (KB, or None if `hi` fails or `lo` succeeds; [(kb, phase failed or None)] in the order run)."""
    tried = []

    def ok(kb):
        got = run_pico(template, frames, scale, kb, tmp, track=False, frozen=frozen)
        tried.append((kb, got.get("failed")))
        return "failed" not in got

    if not ok(hi) or ok(lo):
        return None, tried
    while hi - lo > step:
        mid = (lo + hi) // (2 * step) * step
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi, tried


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.heap_pico", description=__doc__.split("\n")[0])
    p.add_argument("--kb", type=int, nargs="*", default=[0, 100],
                   help="heaps (KB) to run, 0 for the Pico's whole heap (default: 0 100, 100 KB being an"
                        " ESP32 without PSRAM); each row is printed when its run ends")
    p.add_argument("--frozen", action="store_true",
                   help="the image with the firmware frozen in (rp2-pico-frozen) instead of .mpy files")
    p.add_argument("--compare", action="store_true", help="each heap on both images, the .mpy one first")
    p.add_argument("--smallest", type=int, nargs=2, metavar=("LO", "HI"),
                   help="then bisect the smallest heap between LO KB (which must fail) and HI KB (which must not)")
    p.add_argument("--step", type=int, default=2, help="the bisection's resolution, KB (default 2)")
    args = p.parse_args(argv)
    images = [False, True] if args.compare else [args.frozen]
    parts = {frozen: pico_parts(frozen=frozen) for frozen in images}
    if None in parts.values():
        print("bench.heap_pico: the emulated Pico%s is not built (make interpreters)"
              % (" with the frozen firmware" if parts.get(True, 1) is None else ""))
        return 1
    t0 = time.perf_counter()
    notes = []
    with tempfile.TemporaryDirectory(prefix="fluxcal-heap-pico-") as tmp:
        disks = {}
        for frozen in images:
            disk, prep = os.path.join(tmp, "disk%d" % frozen), os.path.join(tmp, "prep")
            os.makedirs(disk)
            os.makedirs(prep, exist_ok=True)
            got = _disk(disk, parts[frozen]["mpy_cross"], prep, frozen)
            disks[frozen] = (flash_with(disk, os.path.join(tmp, "template%d.flash" % frozen), frozen),) + got
        native = all(d[3] for d in disks.values())
        print("## Heap on the emulated Raspberry Pi Pico (firmware %s%s, default %d / %d / %d, loop-back"
              " board)\n" % (" and ".join(_IMAGE[f] for f in images), " with %s for armv6m" % ", ".join(m + ".mpy" for m in MODULES) if native else "",
                              DEFAULT[0], DEFAULT[1], DEFAULT[2]))
        print("gc.mem_alloc() after gc.collect(), the whole heap less the ballast; one run each. Calibrating: after"
              " %d s of a hand rotation, just before finish; survey: after %d s more with stream corrected and"
              " logging on. Peaks: the largest figure after any main-loop pass (the solve inside finish is not"
              " seen).\n" % (SECONDS, SECONDS))
        print_table([], [], None)
        for kb in args.kb:
            for frozen in images:
                template, frames, scale, _native = disks[frozen]
                got = run_pico(template, frames, scale, kb or None, tmp, frozen=frozen)
                total = got.get("heap_total")
                size = kb or (total or 0) // 1024
                who = "the Pico's whole heap, %d B" % total if not kb and total else "ballast"
                name = "rp2 %s (emulated Pico)" % _IMAGE[frozen]
                print(row(name, "32-bit", size, who, [got], "not bisected", notes), flush=True)
                if "harness" in got:
                    notes.append("%s, %s KB: the REPL's state and the harness hold %d B%s" % (
                        _IMAGE[frozen], size, got["harness"], "; the ballast took %d pieces (no block was that"
                        " large)" % got["ballast_pieces"] if got["ballast_pieces"] > 1 else ""))
        if args.smallest:
            for frozen in images:
                template, frames, scale, _native = disks[frozen]
                least, tried = smallest(template, frames, scale, tmp, args.smallest[0], args.smallest[1], frozen,
                                       args.step)
                notes.append("%s: smallest heap that boots, calibrates and surveys (collecting only when full): %s;"
                             " runs: %s" % (_IMAGE[frozen], "%d KB" % least if least else "not between %d and %d KB"
                                            % tuple(args.smallest),
                                            ", ".join("%d KB %s" % (kb, "ok" if f is None else "failed " + f)
                                                      for kb, f in tried)))
    command = " ".join(["python -m desktop.bench.heap_pico"] + (argv if argv is not None else sys.argv[1:]))
    print_table(None, notes, "%s, %.0f s" % (command, time.perf_counter() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
