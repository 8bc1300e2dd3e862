"""The lowest clock at which the emulated Pico keeps up, and the instrument's power from it.

    python -m desktop.bench.power [--window 6] [--low 16]    # about 10-20 wall min on 2 cores
    python -m desktop.bench.power --frozen ...                # the image with the firmware frozen in

What: the firmware as `fluxcal deploy` puts it on the emulated Pico (pico_handheld.PicoHandheld,
idle jumped), started from the REPL after `machine.freq(F)`. rp2040js derives clk_sys from the
PLL and CLOCKS registers, and the runner (devicesim/pico/runner.mjs) spends 1/clk_sys of
emulated time per instruction cycle, so at F the firmware has F cycles per emulated second
while the ADS1292 pair converts at its own rate. At each F, the hand calibration and the
survey spin of pico_session.Session (`window` emulated s each, the finish's solve between);
F keeps up when the firmware counted every conversion (status `frames` against the board's
uptime at the configured rate, within FRAME_SLACK, and where a PIO counts DRDY (status
`drdy_counter`) the decim - window conversions it accounts at a block's first read) and dropped
none (`overflow`, `missed` 0).
Bisection over the whole-MHz clocks the RP2040's PLL makes, from --low to 125 MHz.

Power from it (datasheet figures and what they assume, printed with the table):
- MCU: the RP2040's core supply current scales with clk_sys; MCU_UA_PER_MHZ is the busy
  figure the project's power budget uses (docs/firmware.md: 16-25 mA at 133 MHz, 0.12-0.19
  mA/MHz), at 3.3 V, whole-time (the core's sleep between interrupts saves the clock gating
  of one core only: counted as busy, an upper bound), plus MCU_STATIC_MA (regulator, XOSC,
  PLLs, USB off).
- ADCs: two ADS1292 at 3 V, internal reference, RLD off: 670 uW each [DS 6.5]; the modulator
  runs at fMOD = 128 kHz whatever the data rate, so the figure holds at the configured rate.
"""

import argparse
import os
import shutil
import sys
import tempfile
import time

from desktop.bench.pico import Runner, _raw_exec, delta
from desktop.bench.pico_session import Session, configure
from desktop.devicesim.pico_handheld import PicoHandheld

TOP_MHZ = 125            # the rp2 port's default clk_sys
FRAME_SLACK = 2          # frames: a status reads its count and its uptime a frame apart at each end
MCU_UA_PER_MHZ = (120.0, 190.0)   # RP2040 busy, range (docs/firmware.md's power budget)
MCU_STATIC_MA = 1.0      # RP2040 at any clock: regulator, XOSC, PLLs (assumed; SLEEP is ~0.4 mA)
MCU_V = 3.3
ADS1292_MW = 0.67        # each, 3 V, internal reference, RLD off [DS 6.5]
PAPER_MW = 15.0          # the paper's budget for the instrument


def pll_mhz(mhz):
    """Whether the RP2040's PLL makes exactly `mhz` from the 12 MHz crystal (pico-sdk's
    check_sys_clock_khz: VCO 750-1600 MHz, feedback 16-320, post dividers 1-7)."""
    for fbdiv in range(16, 321):
        vco = 12 * fbdiv
        if 750 <= vco <= 1600:
            for pd1 in range(1, 8):
                for pd2 in range(1, pd1 + 1):
                    if vco == mhz * pd1 * pd2:
                        return True
    return False


def _start_at(hh, dev, hz):
    """Hand the line back, start the firmware again at clk_sys = hz from the REPL; a new Device."""
    from desktop.firmware.deploy import firmware_version
    from desktop.link import open_device, wait_for_version

    dev.ask("repl", timeout=120)
    dev.close()
    _raw_exec(hh.port, "import machine\nmachine.freq(%d)\nimport app, hal_micropython\napp.start(hal_micropython)" % hz)
    wait_for_version(hh.port, firmware_version("micropython"), wait_s=300.0)
    return open_device(hh.port, timeout=120)


def _counted(window, rate):
    """Conversions the firmware missed over a window: the board's uptime at `rate` against its count."""
    first, last = window["samples"][0], window["status"]
    expected = (last["uptime_ms"] - first["uptime_ms"]) * rate / 1000.0
    return expected - (last["frames"] - first["frames"])


def run_at(flash, mhz, window_s, log, frozen=False):
    """One session at mhz on a copy of the deployed flash: its figures."""
    from desktop.firmware.deploy import firmware_version
    from desktop.link import open_device, wait_for_version

    with tempfile.TemporaryDirectory(prefix="fluxcal-power-") as tmp:
        shutil.copy(flash, os.path.join(tmp, "pico.flash"))
        with PicoHandheld(tmp, idle="jump", frozen=frozen) as hh:
            wait_for_version(hh.port, firmware_version("micropython"), wait_s=300.0)
            dev = open_device(hh.port, timeout=120)
            dev = _start_at(hh, dev, mhz * 1000000)
            rate, decim, window = (int(dev.ask("config get " + k, timeout=120)["value"])
                                   for k in ("rate", "decim", "window"))
            runner = Runner(hh.board)
            got = Session(dev, runner.clock, hh.act, runner.figures).run(window_s)
            clk = hh.board.figures()["clk_sys_hz"]
            status = dev.ask("status", timeout=120)
            dev.close()
    out = {"mhz": mhz, "clk_sys_hz": clk, "rate": rate, "overflow": status["overflow"], "missed": status["missed"],
           "result": got["result"]}
    # a PIO-counted board adds the conversions before a block's window to `frames` at its first read
    slack = FRAME_SLACK + (decim - window if status.get("drdy_counter") == "pio" else 0)
    for name in ("calibrating", "survey"):
        d = delta(got[name])
        out[name] = {"load": d["load"], "uncounted": _counted(got[name], rate)}
    out["keeps_up"] = (out["overflow"] == 0 and out["missed"] == 0 and
                       all(out[n]["uncounted"] <= slack for n in ("calibrating", "survey")))
    log("%d MHz: %s (calibrating %.1f %%, survey %.1f %%, overflow %d, missed %d)" % (
        mhz, "keeps up" if out["keeps_up"] else "falls behind", 100 * out["calibrating"]["load"],
        100 * out["survey"]["load"], out["overflow"], out["missed"]))
    return out


def deployed_flash(folder, log, frozen=False):
    """The firmware deployed and configured (auto-finish off) on an emulated Pico: its flash file."""
    from desktop.firmware.deploy import MicroPythonDeploy, firmware_version
    from desktop.link import open_device, wait_for_version

    with PicoHandheld(folder, idle="jump", frozen=frozen) as hh:
        MicroPythonDeploy(hh.port, compiled=True).run()
        wait_for_version(hh.port, firmware_version("micropython"), wait_s=300.0)
        dev = open_device(hh.port, timeout=120)
        configure(dev, dict(hh.wiring_config(), auto_finish=False))
        dev.close()
        flash = hh.flash_file
    log("deployed")
    return flash


def bisect(flash, low, window_s, resolution, log, frozen=False):
    """The lowest whole-MHz PLL clock that keeps up, to `resolution` MHz; the floor the 125 MHz
    run's load sets (below load x 125 MHz the work outgrows the cycles: not run); every run."""
    runs = {TOP_MHZ: run_at(flash, TOP_MHZ, window_s, log, frozen)}
    if not runs[TOP_MHZ]["keeps_up"]:
        return None, low, runs
    busiest = max(runs[TOP_MHZ][n]["load"] for n in ("calibrating", "survey"))
    floor = max(low, int(busiest * TOP_MHZ) + 1)
    clocks = [m for m in range(floor, TOP_MHZ + 1) if pll_mhz(m)]
    lo, hi = 0, len(clocks) - 1       # clocks[hi] keeps up; nothing below clocks[lo] is known to
    while clocks[hi] - clocks[lo] > resolution:
        mid = (lo + hi) // 2
        got = run_at(flash, clocks[mid], window_s, log, frozen)
        runs[clocks[mid]] = got
        if got["keeps_up"]:
            hi = mid
        else:
            lo = mid + 1
    return clocks[hi], floor, runs


def mcu_mw(mhz):
    return tuple(MCU_V * (MCU_STATIC_MA + ua * mhz / 1000.0) for ua in MCU_UA_PER_MHZ)


def print_table(lowest, floor, runs, window_s):
    print("| clk_sys | calibrating: CPU load | survey: CPU load | conversions uncounted, cal / survey (up to 2 when status reads, and decim - window where a PIO counts) | ring overflows | keeps up |")
    print("|---|---|---|---|---|---|")
    for mhz in sorted(runs):
        r = runs[mhz]
        print("| %d MHz | %.1f %% | %.1f %% | %.0f / %.0f | %d | %s |" % (
            mhz, 100 * r["calibrating"]["load"], 100 * r["survey"]["load"], max(0.0, r["calibrating"]["uncounted"]),
            max(0.0, r["survey"]["uncounted"]), r["overflow"], "yes" if r["keeps_up"] else "no"))
    print("\nBelow %d MHz not run: the busiest window's load at %d MHz exceeds the clock there."
          % (floor, TOP_MHZ))
    print()
    adcs = 2 * ADS1292_MW
    print("| power (3.3 V MCU, 3 V ADCs) | MCU | 2 x ADS1292 | instrument | paper |")
    print("|---|---|---|---|---|")
    for label, mhz in (("at %d MHz (today's clock)" % TOP_MHZ, TOP_MHZ),) + (
            (("at %d MHz (lowest that keeps up)" % lowest, lowest),) if lowest else ()):
        lo, hi = mcu_mw(mhz)
        print("| %s | %.0f-%.0f mW | %.2f mW | %.0f-%.0f mW | < %.0f mW |" % (label, lo, hi, adcs, lo + adcs, hi + adcs,
                                                                       PAPER_MW))
    print()
    print("Assumes: RP2040 %.2f-%.2f mA/MHz busy + %.1f mA at %.1f V, the whole time (the core's WFI between"
          " interrupts not credited: an upper bound); ADS1292 %.2f mW each [DS 6.5]; the lowest clock measured on"
          " the emulated Pico over %g emulated s calibrating and %g s in survey (rp2040js: no flash wait states)."
          % (MCU_UA_PER_MHZ[0] / 1000, MCU_UA_PER_MHZ[1] / 1000, MCU_STATIC_MA, MCU_V, ADS1292_MW, window_s, window_s))


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.power", description=__doc__.split("\n")[0])
    p.add_argument("--window", type=float, default=6.0,
                   help="emulated seconds calibrating and in survey at each clock (default 6: one provisional solve)")
    p.add_argument("--low", type=int, default=16, help="lowest clock tried, MHz (default 16)")
    p.add_argument("--resolution", type=int, default=4, help="bisection stops this close, MHz (default 4)")
    p.add_argument("--frozen", action="store_true",
                   help="the image with the firmware frozen in (make pico-frozen) instead of .mpy files")
    args = p.parse_args(argv)
    t0 = time.time()

    def log(msg):
        print("[%4.0f s] %s" % (time.time() - t0, msg), file=sys.stderr, flush=True)
    with tempfile.TemporaryDirectory(prefix="fluxcal-power-base-") as base:
        flash = deployed_flash(base, log, args.frozen)
        lowest, floor, runs = bisect(flash, args.low, args.window, args.resolution, log, args.frozen)
    print_table(lowest, floor, runs, args.window)
    print("\n(command: python -m desktop.bench.power --window %g --low %d --resolution %d%s; %.0f s)" % (
        args.window, args.low, args.resolution, " --frozen" if args.frozen else "", time.time() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
