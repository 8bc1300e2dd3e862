"""The emulated Pico's figures set beside the Cortex-M3 estimate, and printed (desktop/bench/pico.py).

The estimate is desktop/bench/cortexm.py's: MicroPython's instructions counted on qemu's Cortex-M3,
times CYCLES_PER_M3_INSTRUCTION (1.5 for a Cortex-M0+), plus the SPI wire time of each frame read
(WIRE_US, the handler waits for it); here in cycles of the Pico's 125 MHz clock, so the ratio
measured / estimate is clock-free. A part counted per call there (gates, add(), a provisional
solve, an output block) is scaled by the Pico's own calls per second in the same window.
"""

import numpy as np

from desktop.bench.cortexm import CYCLES_PER_M3_INSTRUCTION, count
from desktop.bench.device import WIRE_US
from desktop.firmware.files import REPO, import_device
from desktop.firmware.natmod import natmod_path

CLOCK_HZ = 125e6
# the RP2040's exception numbers (16 + IRQ) the runner may name (pico/parts.mjs)
EXCEPTIONS = {"irq11": "SVCall", "irq14": "PendSV", "irq15": "SysTick", "irq16": "timer alarm 0",
              "irq17": "timer alarm 1", "irq18": "timer alarm 2", "irq19": "timer alarm 3",
              "irq21": "USB", "irq23": "PIO0 IRQ 0", "irq29": "GPIO bank 0"}
CPI = CYCLES_PER_M3_INSTRUCTION["Cortex-M0+"][0]
WIRE_CYCLES = WIRE_US * 1e-6 * CLOCK_HZ
SOLVE_EVERY_S = import_device("config").SCHEMA["solve_every_s"][0]


def m3_counts():
    """cortexm.py's counts of this revision at the default configuration (no sweep), with the
    native sums as the Pico has them from deploy."""
    return count(REPO, native=natmod_path("armv7m"))


def m3_estimate(f, key, calls_per_s, stream):
    """Cycles per second the Cortex-M3 counts `f` give part `key` (None: not counted there)."""
    if f is None:
        return None
    reads = f["rate"] * f["window"] / f["decim"]
    if key == "irq23":     # PIO counted: the handler on the conversions read alone
        return (reads * f["isr_read"] + f["rate"] / f["decim"] * f["isr_push_pop"]) * CPI + reads * WIRE_CYCLES
    if key == "irq29":
        n = (f["rate"] * (f["decim"] - f["window"]) / f["decim"] * f["isr_skip"] + reads * f["isr_read"]
             + f["rate"] / f["decim"] * f["isr_push_pop"])
        return n * CPI + reads * WIRE_CYCLES
    per_call = {"part2": "gates_per_sample", "part3": "add_per_accepted"}.get(key)
    if per_call:
        return f[per_call] * CPI * calls_per_s
    if key == "part4":
        return f["solve_provisional"] * CPI / SOLVE_EVERY_S
    if key == "part5" and stream:
        return f["output_per_block"] * CPI * f["blocks_per_s"]
    if key in ("calibrating", "survey"):
        return f[key + "_per_s"] * CPI + reads * WIRE_CYCLES
    return None


def _pct(cycles_per_s):
    return "-" if cycles_per_s is None else "%.1f %%" % (100 * cycles_per_s / CLOCK_HZ)


def _ratio(measured, estimate):
    return "-" if not estimate else "%.2f" % (measured / estimate)


def _k(n):
    return "%.0f" % n if n < 1e4 else "%.1f k" % (n / 1e3) if n < 1e6 else "%.2f M" % (n / 1e6)


def part_table(name, w, plain, f, stream, parts):
    s = w["emulated_s"]
    print("\n#### %s: where the cycles go (%.1f emulated s, %.0f M cycles)\n" % (name, s, w["cycles"] / 1e6))
    print("| part | calls/s | cycles per call | CPU at 125 MHz | Cortex-M3 estimate | measured / estimate |")
    print("|---|---|---|---|---|---|")
    known = {key for key, _ in parts}
    others = sorted(k for k in w["parts"] if k not in known)
    rows = parts + ([("others", "other exceptions (%s)" % ", ".join(EXCEPTIONS.get(k, k) for k in others))]
                    if others else [])
    for key, label in rows:
        cyc = sum(w["parts"].get(k, 0) for k in others) if key == "others" else w["parts"].get(key, 0)
        calls = sum(w["calls"].get(k, 0) for k in others) if key == "others" else w["calls"].get(key, 0)
        if not cyc and not calls:
            continue
        est = m3_estimate(f, key, calls / s, stream)
        print("| %s | %.1f | %s | %s | %s | %s |" % (label, calls / s, _k(cyc / calls) if calls else "-",
                                                   _pct(cyc / s), _pct(est), _ratio(cyc / s, est)))
    est = m3_estimate(f, name, 0, stream)
    print("| **all, profiled** (the parts above) | | | %s | | |" % _pct(w["awake_cycles"] / s))
    print("| **all, plain firmware** (no profiling) | | | **%s** | %s | **%s** |" % (
        _pct(plain["awake_cycles"] / plain["emulated_s"]), _pct(est),
        _ratio(plain["awake_cycles"] / plain["emulated_s"], est)))


def spin_noise(values):
    """(PTP, sigma of a block, 1 sd of the PTP of as many Gaussian blocks at that sigma)."""
    v = np.asarray(values, dtype=float)
    if len(v) < 3:
        return float("nan"), float("nan"), float("nan")
    sigma = float(np.std(v, ddof=1))
    ranges = np.ptp(np.random.default_rng(0).standard_normal((20000, len(v))), axis=1)
    return float(np.ptp(v)), sigma, float(ranges.std() * sigma)


def print_tables(pico, mp, f, parts=None):
    from desktop.bench.pico import PARTS
    parts = parts or PARTS
    plain, prof = pico["plain"], pico.get("profiled")     # None: the profiled session failed
    pc, ps = plain["calibrating"], plain["survey"]
    rows = [
        ("deploy (.mpy, empty flash)", "%.1f wall s" % pico["deploy_wall_s"], "mpy-cross, mpremote, the emulator"),
        ("boot: reset to the main loop", "%.2f emulated s" % pico["boot_s"], ""),
        ("heap free after boot", "%d B" % pico["heap_boot"], "of 245,888 B at the REPL"),
        ("heap free calibrating: end / lowest sampled", "%d / %d B" % (pc["mem_free"], pc["mem_free_min"]),
         "garbage not yet collected counts as used"),
        ("heap free in survey: end / lowest sampled", "%d / %d B" % (ps["mem_free"], ps["mem_free_min"]), ""),
        ("missed conversions / ring overflows", "%d / %d" % (ps["missed"], ps["overflow"]), "the firmware's counts"),
    ]
    for label, w, key in (("calibrating", pc, "calibrating"), ("survey, stream on", ps, "survey")):
        est = m3_estimate(f, label.split(",")[0], 0, True)
        # two decimals: the survey's target (5 %) is where one decimal can no longer tell the side
        rows.append(("CPU load %s (cycles awake / cycles)" % label, "%.2f %%" % (100 * w["load"]),
                     "Cortex-M3 estimate %s, measured / estimate %s; profiled %s" % (
                         _pct(est), _ratio(w["awake_cycles"] / w["emulated_s"], est),
                         "-" if prof is None else "%.1f %%" % (100 * prof[key]["load"]))))
        rows.append(("DRDY to read, %s: mean / worst" % label, "%.0f / %.0f us" % (w["latency_us"], w["latency_max_us"]),
                     "%d reads; %d conversions not read (decimation, by design)" % (w["reads"], w["unread"])))
        s = w["emulated_s"]
        rows.append(("wall cost, %s" % label, "%.2f wall s per emulated s" % (w["wall_s"] / s),
                     "CPU: emulator %.2f s, Python (world, relay) %.2f s; the core waited %.2f s on %d bridge"
                     " round trips" % (w["node_cpu_s"] / s, w["python_cpu_s"] / s, w["bridge_wait_s"] / s,
                                       w["requests"] / s)))
    print("### The firmware on the emulated Pico (rp2 firmware, RP2040 at 125 MHz)\n")
    print("| what | figure | note |")
    print("|---|---|---|")
    for name, fig, note in rows:
        print("| %s | %s | %s |" % (name, fig, note))
    if prof is None:
        print("\n(no split by part: the profiled session failed: %s)" % pico.get("profiled_error"))
    else:
        part_table("calibrating", prof["calibrating"], pc, f, False, parts)
        part_table("survey", prof["survey"], ps, f, True, parts)
    print("\n#### A hand calibration's spin: PTP of the streamed |B| over one turn a second\n")
    print("| runtime | calibration (n, rms nT) | blocks | PTP (nT) | sigma of a block (nT) | PTP's noise, 1 sd (nT) |")
    print("|---|---|---|---|---|---|")
    for name, run in (("emulated Pico", plain), ("emulated Pico, profiled", prof), ("micropython", mp)):
        if run is None:
            continue
        r = run["result"]
        ptp, sigma, sd = spin_noise(run["spin"])
        print("| %s | %s, %s | %d | %.3f | %.3f | %.3f |" % (name, r.get("n"), r.get("rms"), len(run["spin"]),
                                                            ptp, sigma, sd))
