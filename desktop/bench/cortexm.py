"""Instruction counts on an emulated Cortex-M3, and the microcontroller load they give.

    python -m desktop.bench.cortexm                     # markdown tables (docs/firmware.md)
    python -m desktop.bench.cortexm --before 08bdee5    # beside the counts of a former revision

What: MicroPython's bare-metal port on ARM's MPS2-AN385 (Cortex-M3, software floats,
240 KB heap, a Pico's) in qemu-system-arm with -icount shift=0, where one instruction takes one
nanosecond of the board's clock, so ticks_us() differences x 1000 count instructions
(desktop/devicesim/qemu_board.py). Counted there, in the revision's own code compiled
to .mpy and run from the board's ROM filesystem, with the fit's native sums (fitsums.mpy for
armv7m, desktop/firmware/natmod.py) and the solver's float kernels (linalgc.mpy) as deploy installs
them where built (--before: pure Python):
- micropython-scripts/cortexm_core.py: EllipsoidFit.add() with and without the garbage
  collections it causes, the bytes it leaves, solve() (a 1300-sample distorted sphere);
- micropython-scripts/cortexm_firmware.py: the firmware's App on a LoopBoard fed a
  simulated hand rotation at the default configuration: the DRDY handler per frame, the
  calibration gates per decimated sample and add() per accepted one (replays of recorded
  samples), a solve, one survey output block, and the whole main loop per second of data
  while calibrating (provisional solves included) and in survey (streaming corrected).
Counts are deterministic: one run each.

Why: the RP2040 load was unix-port microseconds times an assumed 40. Instructions are not
cycles; the conversion is stated where it is used (CYCLES_PER_M3_INSTRUCTION).
"""

import argparse
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from desktop.bench.device import DEFAULT, SWEEP, WIRE_US, frame_table
from desktop.devicesim.qemu_board import QemuBoard
from desktop.firmware.files import REPO, import_device
from desktop.firmware.interpreters import interpreter, mpy_cross_exe
from desktop.firmware.natmod import natmod_path

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts")
SECONDS = 15
# Cycles per Cortex-M3 instruction counted here, (typical, low, high), for the same C compiled
# for each core. Cortex-M0+ (ARMv6-M, RP2040): Thumb-1 only, so ~1.1-1.3x the instructions,
# and 2-cycle loads and taken branches, ~1.1-1.5 cycles each; flash (XIP cache) misses come
# on top. Cortex-M4 (ARMv7E-M): the same instructions as the M3, ~1.0-1.3 cycles each; with
# its FPU the software-float share counted here shrinks, so this is an upper bound there.
CYCLES_PER_M3_INSTRUCTION = {"Cortex-M0+": (1.5, 1.2, 2.0), "Cortex-M4": (1.1, 1.0, 1.3)}
CLOCK_HZ = {"Cortex-M0+": 133e6, "Cortex-M4": 80e6}
DEVICE_ONLY = ("main.py", "code.py", "boot.py")


def _mpy(src, out):
    os.makedirs(os.path.dirname(out), exist_ok=True)
    r = subprocess.run([mpy_cross_exe(), "-O1", "-s", os.path.basename(src), "-o", out, src], capture_output=True, text=True)
    if r.returncode:
        raise RuntimeError("mpy-cross %s: %s" % (src, r.stderr.strip()))


def make_rom(tree, rom, configs, native=None):
    """The board's ROM: tree's device/ and shared/ as a board's /lib of .mpy (with native, the
    fit's native sums fitsums.mpy, and the solver's float kernels linalgc.mpy where built, as deploy
    adds them), the bench scripts, and per configuration
    (rate, decim, window; None: tree's defaults) a flash folder holding its config, with a frame
    file per rate."""
    lib = os.path.join(rom, "lib")
    if native:
        os.makedirs(lib, exist_ok=True)
        shutil.copyfile(native, os.path.join(lib, "fitsums.mpy"))
        kernels = natmod_path("armv7m", "linalgc")
        if kernels:
            shutil.copyfile(kernels, os.path.join(lib, "linalgc.mpy"))
    for sub, dest in (("device", lib), ("shared", os.path.join(lib, "shared"))):
        for name in sorted(os.listdir(os.path.join(tree, sub))):
            if name.endswith(".py") and name not in DEVICE_ONLY:
                _mpy(os.path.join(tree, sub, name), os.path.join(dest, name[:-3] + ".mpy"))
    for name in ("loopboard", "cortexm_core", "cortexm_firmware"):
        _mpy(os.path.join(SCRIPTS, name + ".py"), os.path.join(rom, name + ".mpy"))
    store = import_device("store")
    runs = []
    for cfg in configs:
        rate = cfg[0] if cfg else default_rate(tree)
        frames = os.path.join(rom, "frames%d.bin" % rate)
        if not os.path.exists(frames):
            with open(frames, "wb") as fh:
                fh.write(frame_table(seconds=20.0, rate=rate)[0])
        flash = os.path.join(rom, "flash-%d-%d-%d" % cfg if cfg else "flash")
        os.makedirs(flash)
        # the simulated handheld's nT per code is the default scale; no auto-finish: the bench
        # finishes the session itself, without storing (the ROM is read-only)
        body = {"auto_finish": False}
        if cfg:
            body.update(rate=cfg[0], decim=cfg[1], window=cfg[2])
        store.save(flash, "config", body)
        runs.append(("/rom/" + os.path.basename(frames), "/rom/" + os.path.basename(flash), rate))
    return runs


def default_rate(tree):
    """The data rate tree's firmware configures by default (its device/config.py)."""
    spec = importlib.util.spec_from_file_location("_config_of_tree", os.path.join(tree, "device", "config.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.SCHEMA["rate"][0]


def count(tree, sweep=(), native=None):
    """{"core": {...}, "firmware": {...}, "sweep": {cfg: {...}}} counted on fresh boards with
    tree's code: the units and loops at tree's default configuration, fed a hand rotation at
    its data rate, and the loops alone at each configuration of `sweep`. native: fitsums.mpy
    for armv7m, or None (pure-Python sums)."""
    out = {"sweep": {}}
    with tempfile.TemporaryDirectory() as tmp:
        rom = os.path.join(tmp, "rom")
        runs = make_rom(tree, rom, [None] + list(sweep), native)
        calls = [("core", "import cortexm_core\ncortexm_core.main()")]
        for cfg, (frames, flash, rate) in zip([None] + list(sweep), runs):
            calls.append((cfg or "firmware", "import cortexm_firmware\ncortexm_firmware.main(%r, %r, %d, %d, unit_counts=%s)"
                          % (frames, flash, rate, SECONDS, cfg is None)))
        for key, call in calls:
            with QemuBoard(rom=rom) as board:
                got = json.loads(board.exec(call, timeout=1800).strip().splitlines()[-1])
            if isinstance(key, tuple):
                out["sweep"][key] = got
            else:
                out[key] = got
    return out


def checkout(rev, dest):
    """shared/ and device/ of a former revision, from git."""
    os.makedirs(dest)
    archive = subprocess.run(["git", "-C", REPO, "archive", rev, "shared", "device"], capture_output=True, check=True)
    subprocess.run(["tar", "x", "-C", dest], input=archive.stdout, check=True)
    return dest


def load(per_s, reads_per_s, core):
    """Share of the core's clock: instructions x cycles per instruction, plus the SPI wire time
    (machine.SPI.readinto blocks while the bytes go out), for (typical, low, high)."""
    return [100 * (per_s * c / CLOCK_HZ[core] + reads_per_s * WIRE_US * 1e-6)
            for c in CYCLES_PER_M3_INSTRUCTION[core]]


def _k(n):
    return "%.1f k" % (n / 1e3) if n < 1e6 else "%.2f M" % (n / 1e6)


def print_tables(now, before=None, rev=None):
    cols = [("now", now)] + ([("before (%s)" % rev, before)] if before else [])
    f = now["firmware"]
    print("### Instructions on an emulated Cortex-M3 (qemu mps2-an385, MicroPython %s bare-metal,"
          " software floats, .mpy from ROM)\n" % "1.29")
    print("| path | " + " | ".join(name for name, _ in cols) + " |")
    print("|---|" + "---|" * len(cols))
    rows = [
        ("EllipsoidFit.add(), garbage collection off (instructions)", "core", "add_no_gc", _k),
        ("EllipsoidFit.add(), heap bytes it leaves", "core", "add_bytes", str),
        ("EllipsoidFit.add(), collections included (1300 calls)", "core", "add", _k),
        ("EllipsoidFit.solve() (1300-sample sphere)", "core", "solve", _k),
        ("solve() iterations", "core", "iterations", str),
        ("quick re-calibration solve(prior=...) of the same sums (gain models + shape test)", "core",
         "solve_quick", _k),
        ("Calibration.at_temperature() (survey: once per 0.05 C of the die)", "core", "at_temperature", _k),
        ("DRDY handler, frame outside the boxcar", "firmware", "isr_skip", _k),
        ("DRDY handler, frame in the boxcar (2 x 9-byte reads, parse, sum)", "firmware", "isr_read", _k),
        ("DRDY handler end of block + ring pop", "firmware", "isr_push_pop", _k),
        ("calibration gates per decimated sample", "firmware", "gates_per_sample", _k),
        ("add() per accepted sample, in the firmware (collections included)", "firmware", "add_per_accepted", _k),
        ("solve() of the firmware's fit (%d samples)" % f["replay_accepted"], "firmware", "solve", _k),
        ("provisional solve of the same fit (every solve_every_s while calibrating)", "firmware",
         "solve_provisional", _k),
        ("one garbage collection of the calibrating firmware's heap", "firmware", "gc_collect", _k),
        ("survey output per block (correct, format the data event)", "firmware", "output_per_block", _k),
        ("whole firmware calibrating, per second of data", "firmware", "calibrating_per_s", _k),
        ("whole firmware in survey (stream corrected), per second of data", "firmware", "survey_per_s", _k),
    ]
    for label, part, key, fmt in rows:
        cells = [fmt(v[part][key]) if key in v.get(part, {}) else "n/a" for _, v in cols]
        print("| %s | %s |" % (label, " | ".join(cells)))
    reads = f["rate"] * f["window"] / f["decim"]
    print("\nCalibrating run: %d s of a hand rotation at %d / %d / %d, %d decimated samples, %d accepted, %d"
          " provisional solves, state %s; its steady state per second is the loop without those solves plus one"
          " provisional solve per 5 s (the loop itself: %s). Replays: %d samples, %d accepted. Heap held while"
          " calibrating: %d bytes. The solver's float kernels: %s (device/app.py's boot rule)."
          % (SECONDS, f["rate"], f["decim"], f["window"], f["cal_seen"], f["cal_accepted"], f["cal_solves"],
             f["cal_state"], _k(f["calibrating_loop_per_s"]), f["replay_samples"], f["replay_accepted"],
             f["heap_live_calibrating"], "taken" if f.get("linalg") == "native" else "not taken"))
    print("\n### Load at the default configuration, from the counts\n")
    print("Instructions x cycles per Cortex-M3 instruction (typical, range) / clock, plus the SPI wire time"
          " (%d frame reads/s x %.0f us, blocking).\n" % (reads, WIRE_US))
    print("| core, clock | cycles per M3 instruction | calibrating | survey (stream corrected) |" +
          (" calibrating, before (%d / %d / %d) |" % tuple(before["firmware"][k] for k in ("rate", "decim", "window"))
           if before else ""))
    print("|---|---|---|---|" + ("---|" if before else ""))
    for core in ("Cortex-M0+", "Cortex-M4"):
        cyc = CYCLES_PER_M3_INSTRUCTION[core]
        cells = [load(f[k], reads, core) for k in ("calibrating_per_s", "survey_per_s")]
        if before:
            b = before["firmware"]
            cells.append(load(b["calibrating_per_s"], b["rate"] * b["window"] / b["decim"], core))
        print("| %s, %.0f MHz | %.1f (%.1f-%.1f) | %s |" % (
            core, CLOCK_HZ[core] / 1e6, *cyc, " | ".join("%.1f %% (%.1f-%.1f)" % tuple(x) for x in cells)))
    print("\nWhere the calibrating second goes (counts x rates; the rest is the main loop, button, serial, LED):\n")
    block_rate = f["rate"] / f["decim"]
    accept_rate = f["cal_accepted"] / SECONDS
    parts = [
        ("DRDY handler", f["rate"] * (f["decim"] - f["window"]) / f["decim"] * f["isr_skip"] + reads * f["isr_read"]
         + block_rate * f["isr_push_pop"]),
        ("gates (%.0f samples/s)" % block_rate, block_rate * f["gates_per_sample"]),
        ("add() (%.0f accepted/s)" % accept_rate, accept_rate * f["add_per_accepted"]),
        ("provisional solve every %d s" % 5, f["solve_provisional"] / 5.0),
    ]
    parts.append(("the rest: main-loop passes, survey averaging, collections, progress events",
                  f["calibrating_per_s"] - sum(n for _, n in parts)))
    print("| part | instructions per s | share of the measured loop |")
    print("|---|---|---|")
    for label, n in parts:
        print("| %s | %s | %.0f %% |" % (label, _k(n), 100 * n / f["calibrating_per_s"]))
    if now.get("sweep"):
        core = "Cortex-M0+"
        cyc = CYCLES_PER_M3_INSTRUCTION[core]
        print("\n### The sweep's load on a %s at %.0f MHz, from the counts (%.1f cycles per M3 instruction, range"
              " %.1f-%.1f; the accuracy of each configuration: python -m desktop.bench.device)\n"
              % (core, CLOCK_HZ[core] / 1e6, *cyc))
        print("| rate / decim / window | calibrating, instructions per s | load calibrating | survey (stream corrected)"
              " | load survey | provisional solve stall |")
        print("|---|---|---|---|---|---|")
        for cfg, r in sorted(now["sweep"].items(), key=lambda kv: SWEEP.index(kv[0])):
            reads = r["rate"] * r["window"] / r["decim"]
            lc, ls = load(r["calibrating_per_s"], reads, core), load(r["survey_per_s"], reads, core)
            stall = [r["solve_provisional_loop"] * c / CLOCK_HZ[core] for c in cyc]
            print("| %d / %d / %d%s | %s | %.1f %% (%.1f-%.1f) | %s | %.1f %% (%.1f-%.1f) | %.2f s (%.2f-%.2f) |"
                  % (cfg + (" (default)" if cfg == DEFAULT else "", _k(r["calibrating_per_s"]), *lc,
                            _k(r["survey_per_s"]), *ls, *stall)))


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.cortexm", description=__doc__.splitlines()[0])
    p.add_argument("--before", metavar="REV", help="also count a former revision's shared/ and device/ (git)")
    args = p.parse_args(argv)
    if interpreter("qemu-m3") is None:
        print("qemu-m3 is not built: make interpreters")
        return 1
    t0 = time.time()
    now = count(REPO, SWEEP, natmod_path("armv7m"))     # as deploy puts it on an armv7m board
    before = None
    if args.before:
        with tempfile.TemporaryDirectory() as tmp:
            before = count(checkout(args.before, os.path.join(tmp, "tree")))
    print_tables(now, before, args.before)
    print("\n(command: python -m desktop.bench.cortexm%s; %.0f s)" % (
        " --before " + args.before if args.before else "", time.time() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
