"""The main loop's own cost on the emulated Raspberry Pi Pico: cycles a pass, piece by piece.

    python -m desktop.bench.pico_loop                      # this checkout's device/ and shared/
    python -m desktop.bench.pico_loop --source OTHER_TREE  # another checkout's, to compare

What: micropython-scripts/pico_loop.py builds device/app.py's App on the rp2 HAL of the rp2
port's firmware in the RP2040 emulator (the firmware's modules as .mpy from the Pico's own
mpy-cross, the native modules for armv6m as deploy installs them; no chips on the pins, the
supervisor then put in a healthy boot's state, so no samples flow) and runs its main-loop pass
250 times (5 emulated s) after boot, then 250 more with a calibration session started: each
piece of step() named on the runner's profiling port (desktop/devicesim/pico/parts.mjs), which
counts the cycles the core runs in thread mode in it (the interrupts apart: their own rows), then
App.run() itself for 5 emulated s (its thread-mode cycles, the wake-ups' C code in its
sleep_ms(_HOUSE_MS) included; the passes counted from the run's emulated time). The collector
is off while the cycles are counted; the bytes a pass allocates, by piece, are counted apart:
garbage a collection pays for later. A port write's own cost is measured and taken off each
piece.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

from desktop.bench.pico_gates import mpy_disk
from desktop.devicesim.pico_board import PicoBoard
from desktop.firmware.files import REPO

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts", "pico_loop.py")
MHZ = 125
# the script's piece numbers (added to a phase's 100 or 200) and their rows
PIECES = [(1, "acq.poll (the ring, empty)"), (2, "supervisor.check (health)"), (3, "button.poll"),
          (4, "proto.poll (the serial line, nothing waiting)"), (5, "flow.tick (a session's progress)"),
          (6, "led.update"), (7, "guard.passed"), (8, "the watchdog's feed"),
          (9, "wait(): sleep_ms(20), awake in it (the wake-ups)")]
ALLOC = [("check", 2), ("button", 3), ("proto", 4), ("tick", 5), ("led", 6), ("passed", 7), ("feed", 8)]
WRITE, WHOLE = 10, 20


def _disk(folder, source):
    """The firmware's modules from `source` as .mpy for the Pico, the script, the native modules."""
    device = [n[:-3] for n in sorted(os.listdir(os.path.join(source, "device")))
              if n.endswith(".py") and n not in ("main.py", "boot.py", "code.py", "boot_micropython.py",
                                                  "hal_circuitpython.py", "manifest.py")]
    mpy_disk(folder, source, device, [(SCRIPT, "pico_loop.py")])


def run(source):
    """(the script's JSON, the runner's parts {key: cycles}, {key: calls}) or None."""
    with tempfile.TemporaryDirectory(prefix="fluxcal-pico-loop-") as tmp:
        disk = os.path.join(tmp, "disk")
        _disk(disk, source)
        with PicoBoard(os.path.join(tmp, "pico.flash"), idle="jump") as board:
            r = subprocess.run([sys.executable, "-m", "mpremote", "connect", board.port, "cp", "-r", disk, ":",
                                "+", "exec", "import sys; sys.path.insert(0, '/disk'); import pico_loop"],
                               capture_output=True, text=True, timeout=1800)
            parts = board.figures()["parts"] if not r.returncode else None
    if r.returncode:
        print("the Pico run failed: %s" % (r.stdout + r.stderr).strip()[-800:], file=sys.stderr)
        return None
    return json.loads(r.stdout.splitlines()[-1]), parts["cycles"], parts["calls"]


def table(got, cycles, calls, source):
    n = got["passes"]
    lines = ["| a main-loop pass on the emulated Pico (no samples; %s) | after boot: cycles a pass | "
             "bytes allocated | with a session: cycles a pass | bytes allocated |" % source, "|---|---|---|---|---|"]

    def per(base, k, write):
        c = cycles.get("part%d" % (base + k), 0.0)
        m = calls.get("part%d" % (base + k), 0) or 1
        return c / m - write

    writes = {base: per(base, WRITE, 0.0) for base in (100, 200)}
    alloc = dict(ALLOC)
    total = {100: 0.0, 200: 0.0}
    for k, label in PIECES:
        row = "| %s |" % label
        for base, key in ((100, "alloc"), (200, "alloc_session")):
            c = per(base, k, writes[base])
            total[base] += c
            name = [a for a, j in alloc.items() if j == k]
            b = got[key].get(name[0]) if name else None
            row += " %s | %s |" % ("{:,}".format(round(c)), "-" if b is None else "%.0f" % b)
        lines.append(row)
    row = "| **the pieces' sum** |"
    for base in (100, 200):
        row += " **%s** | |" % "{:,}".format(round(total[base]))
    lines.append(row)
    row = "| **App.run() itself: a pass (step, guard, feed, the wake-ups in its sleep)** |"
    share = []
    for base, key in ((100, "run_us"), (200, "run_us_session")):
        c = cycles.get("part%d" % (base + WHOLE), 0.0)
        # a pass is _HOUSE_MS asleep plus its awake time: the passes from the run's emulated time
        passes = (got[key] - c / MHZ) / (got["house_ms"] * 1000.0)
        share.append(100.0 * c / (got[key] * MHZ))
        row += " **%s** | %.0f (step) |" % ("{:,}".format(round(c / passes)), got[key.replace("run_us", "alloc")]["step"])
    lines.append(row)
    lines.append("| **App.run(): its share of 125 MHz** | **%.2f %%** | | **%.2f %%** | |" % tuple(share))
    lines.append("")
    lines.append("A port write (taken off each row): %.0f / %.0f cycles. Interrupts over the whole run (thread "
                 "mode apart): %s. %d passes a phase; heap free after boot %d B; the probe: %s, the supervisor "
                 "at the end: %s; watchdog %s ms." % (
                     writes[100], writes[200],
                     ", ".join("%s %s cycles in %d" % (k, "{:,}".format(round(cycles[k])), calls.get(k, 0))
                               for k in sorted(cycles) if k.startswith("irq")),
                     n, got["free"], got["probe"], got["fault"], got["watchdog"]))
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.pico_loop", description=__doc__.splitlines()[0])
    p.add_argument("--source", default=REPO, help="the tree whose device/ and shared/ run (default: this one)")
    args = p.parse_args(argv)
    source = os.path.abspath(args.source)
    got = run(source)
    if got is None:
        return 1
    print(table(got[0], got[1], got[2], source))
    return 0


if __name__ == "__main__":
    sys.exit(main())
