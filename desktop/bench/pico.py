"""The firmware measured on the emulated Raspberry Pi Pico: the rp2 port's own firmware on an RP2040
at 125 MHz (desktop/devicesim/pico_handheld.py), every load figure in emulated cycles, not estimates.

    python -m desktop.bench.pico [--window 10]      # about 6-10 min on a 2-core machine
    python -m desktop.bench.pico --frozen           # the image with the firmware frozen in (make pico-frozen)
    python -m desktop.bench.pico --status-every 1000   # no status request inside a window

What, on one emulated Pico (idle time jumped, the operator following the LED):
- deploy: `fluxcal deploy`'s code (.mpy for armv6m; with --frozen the rp2-pico-frozen image, whose
  modules are in flash, and deploy installs main.py and the native modules) onto an empty flash, wall s; boot: emulated
  time from the reset that ends the deploy to the firmware's main loop;
- a hand calibration (pico_session.py): `window` emulated s calibrating (auto-finish off), the
  finish, then `window` s of a steady spin in survey with the stream on (corrected);
- CPU load: cycles awake / cycles in each window, from the runner's count of the cycles the core
  slept (WFI/WFE); DRDY to read: emulated time from DRDY's fall to the first SCLK of chip 0's read,
  mean and worst; missed conversions and ring overflows: the firmware's own counts (status);
- heap: status's mem_free after boot, at the end of each window and its lowest sample in it
  (a sample every --status-every board s, 2.5 by default: each request is firmware work, counted
  in the window's load like any other);
- the load by part: the same session again with the firmware started from the REPL by
  micropython-scripts/pico_parts.py, which names the part that runs on the runner's profiling
  port (desktop/devicesim/pico/parts.mjs); the DRDY handler (PIO0's interrupt, on the conversions
  the boxcar reads: hal_micropython.Board.count_drdy) and the other interrupts are counted
  by the runner from the exceptions themselves. The profiled total beside the plain one is what
  the profiling costs. Beside each: the Cortex-M3 estimate (pico_compare.py) and the ratio;
- the spin's PTP of |B| against the same session on the `micropython` runtime;
- wall cost: emulated s per wall s, and how much of the wall time the world bridge's round trips took.
The wall figures depend on the host's load (other jobs on its 2 cores); the cycle figures do not.
"""

import argparse
import os
import sys
import tempfile
import threading
import time

import serial

from desktop.bench import pico_compare
from desktop.bench.pico_session import SAMPLE_S, Session, configure
from desktop.devicesim.pico_handheld import PicoHandheld

CYCLE_NS = 8          # 125 MHz
SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts", "pico_parts.py")
# the runner's keys (parts.mjs) and what they are: part N as pico_parts.py numbers them,
# irqE the exception E (16 + the RP2040's IRQ number)
PARTS = [("irq23", "DRDY handler (hard IRQ 7, PIO0's: its state machine counts the conversions not read; SPI reads included)"),
         ("irq29", "DRDY handler on the pin (hard IRQ 13, GPIO bank 0: where no PIO counts)"),
         ("part1", "spike screen"),
         ("part2", "calibration gates (rate, coverage cell, disturbance)"),
         ("part3", "add()"),
         ("part11", "residual batches: a batch's sums at its end (in the gates)"),
         ("part4", "solve (provisional every 5 s; the final one in the finish)"),
         ("part10", "calibration progress (the session's pass: progress events, LED, auto-finish; less its solves)"),
         ("part8", "finish: checks, temperature coefficients, save (less its solve)"),
         ("part5", "survey output (|h_c|, blocks, data events)"),
         ("part6", "protocol (the serial line)"),
         ("part9", "button, LED, ADC health (polled every pass)"),
         ("part7", "the pass's sleep (sleep_ms: its wake-ups at each interrupt)"),
         ("irq21", "USB interrupt"),
         ("part0", "the rest of the main loop (the pass and the calls around its parts, the watchdog)")]


class Runner:
    """The emulated Pico's figures (PicoBoard.figures) with the worst DRDY-to-read latency kept
    over every look since a window opened (the runner's worst restarts at each look)."""

    def __init__(self, board):
        self.board = board
        self.worst = 0

    def figures(self, start=False):
        f = self.board.figures()
        self.worst = 0 if start else max(self.worst, f["bridge"]["latencyMaxNs"])
        f["worst_ns"] = self.worst
        f["node_cpu_s"] = _cpu_s(self.board.proc.pid)
        t = os.times()
        f["python_cpu_s"] = t.user + t.system      # the world, the relay and this bench's threads
        return f

    def clock(self):
        return self.figures()["ns"] / 1e9


def _cpu_s(pid):
    """CPU seconds (user + system) process `pid` has used (Linux /proc; nan elsewhere)."""
    try:
        with open("/proc/%d/stat" % pid) as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return float("nan")


def delta(window):
    """Figures of one window: load, latency, wall split, cycles by part."""
    a, b = window["before"], window["after"]
    ns = b["ns"] - a["ns"]
    awake = ns - (b["asleep_ns"] - a["asleep_ns"])
    ba, bb = a["bridge"], b["bridge"]
    reads = bb["reads"] - ba["reads"]
    out = {"emulated_s": ns / 1e9, "wall_s": (b["wall_ms"] - a["wall_ms"]) / 1e3, "load": awake / ns,
           "cycles": ns / CYCLE_NS, "awake_cycles": awake / CYCLE_NS, "reads": reads,
           "latency_us": (bb["latencySumNs"] - ba["latencySumNs"]) / reads / 1e3 if reads else float("nan"),
           "latency_max_us": b["worst_ns"] / 1e3, "unread": bb["unread"] - ba["unread"],
           "bridge_wait_s": (bb["waitMs"] - ba["waitMs"]) / 1e3,
           "requests": bb["requests"] - ba["requests"], "parts": {}, "calls": {},
           "node_cpu_s": b["node_cpu_s"] - a["node_cpu_s"], "python_cpu_s": b["python_cpu_s"] - a["python_cpu_s"]}
    for key in set(b["parts"]["cycles"]) | set(a["parts"]["cycles"]):
        out["parts"][key] = b["parts"]["cycles"].get(key, 0) - a["parts"]["cycles"].get(key, 0)
        out["calls"][key] = b["parts"]["calls"].get(key, 0) - a["parts"]["calls"].get(key, 0)
    statuses = window["samples"]
    out["mem_free"] = window["status"]["mem_free"]
    out["mem_free_min"] = min(s["mem_free"] for s in statuses)
    out["missed"] = window["status"]["missed"]
    out["overflow"] = window["status"]["overflow"]
    return out


def _raw_exec(port, code, timeout=300.0):
    """Run `code` from MicroPython's raw REPL on `port` after a soft reset, without waiting for
    it to end. The soft reset gives it the heap the firmware boots with (boot.py runs, main.py
    does not in the raw REPL): started in the heap the plain firmware left, the profiled one ran
    short of it (start-cal refused with no_memory, the board reset under finish-cal)."""
    with serial.Serial(port, timeout=0.1) as ser:
        end = time.monotonic() + timeout
        got = bytearray()    # one buffer: the reboot's lines and the next prompt can come in one read

        def until(marker, what, start=0):
            """Read until `marker` appears at or after `start`; the position just past it."""
            while True:
                at = got.find(marker, start)
                if at >= 0:
                    return at + len(marker)
                if time.monotonic() > end:
                    raise RuntimeError("%s on %s: %r" % (what, port, bytes(got[-200:])))
                got.extend(ser.read(4096))
                if b">>> " in got[-8:]:
                    ser.write(b"\x01")
        ser.write(b"\r\x01")
        at = until(b"raw REPL; CTRL-B to exit\r\n>", "no raw REPL")
        ser.write(b"\x04")
        at = until(b"soft reboot", "no soft reboot", at)
        until(b"raw REPL; CTRL-B to exit\r\n>", "no raw REPL after the soft reboot", at)
        ser.write(code.encode() + b"\x04")
        taken = b""
        while b"OK" not in taken:
            if time.monotonic() > end:
                raise RuntimeError("the raw REPL on %s did not take the script: %r" % (port, taken[-200:]))
            taken += ser.read(64)


def _profiled_firmware(hh, dev):
    """Hand the line back, then start the firmware again under pico_parts.py, after a soft reset;
    a new Device."""
    from desktop.firmware.deploy import firmware_version
    from desktop.link import open_device, wait_for_version

    dev.ask("repl", timeout=120)
    dev.close()
    with open(SCRIPT) as fh:
        code = "\n".join(ln for ln in fh.read().splitlines() if not ln.lstrip().startswith("#"))
    _raw_exec(hh.port, code)
    wait_for_version(hh.port, firmware_version("micropython"), wait_s=300.0)
    return open_device(hh.port, timeout=120)


def pico_run(window_s, log, frozen=False, status_every=SAMPLE_S):
    from desktop.firmware.deploy import MicroPythonDeploy, firmware_version
    from desktop.link import DeviceError, open_device, wait_for_version

    with tempfile.TemporaryDirectory(prefix="fluxcal-pico-bench-") as tmp:
        with PicoHandheld(tmp, idle="jump", frozen=frozen) as hh:
            t = time.monotonic()
            MicroPythonDeploy(hh.port, compiled=True).run()
            deploy_wall = time.monotonic() - t
            log("deployed in %.1f wall s" % deploy_wall)
            # a request sent while it boots is lost, as on a board re-enumerating: ask until it answers
            wait_for_version(hh.port, firmware_version("micropython"), wait_s=300.0)
            dev = open_device(hh.port, timeout=120)
            st = dev.ask("status")
            f = hh.board.figures()
            out = {"deploy_wall_s": deploy_wall, "boot_s": f["ns"] / 1e9 - st["uptime_ms"] / 1e3,
                   "heap_boot": st["mem_free"]}
            configure(dev, dict(hh.wiring_config(), auto_finish=False))
            runner = Runner(hh.board)
            for name in ("plain", "profiled"):
                if name == "profiled":
                    dev = _profiled_firmware(hh, dev)
                log("%s session" % name)
                try:
                    got = Session(dev, runner.clock, hh.act, runner.figures, status_every).run(window_s)
                except DeviceError as e:
                    # the profiled firmware (its wrappers in the heap) can be refused start-cal for
                    # no_memory: the plain run's figures stand, without the split by part
                    if name == "plain":
                        raise
                    log("%s session failed: %s" % (name, e))
                    out["profiled_error"] = str(e)
                    break
                out[name] = {"calibrating": delta(got["calibrating"]), "survey": delta(got["survey"]),
                             "result": got["result"], "spin": got["spin"]}
            dev.close()
    return out


def micropython_spin(window_s, log):
    """The same session on the `micropython` runtime's virtual handheld (real time): its spin."""
    from desktop.devicesim.runners import install_firmware
    from desktop.devicesim.virtual_handheld import VirtualHandheld
    from desktop.firmware.files import import_device
    from desktop.link import open_device

    with tempfile.TemporaryDirectory(prefix="fluxcal-pico-bench-mp-") as tmp:
        flash = os.path.join(tmp, "flash")
        os.makedirs(flash)
        hh = VirtualHandheld(flash, runtime="micropython")
        install_firmware(flash, hh.runtime)
        import_device("store").save(flash, "config", dict(hh.wiring_config(), auto_finish=False))
        with hh:
            dev = open_device(hh.port, timeout=30)
            log("micropython session")
            got = Session(dev, lambda: hh.world.time, hh.act).run(window_s)
            dev.close()
    return {"result": got["result"], "spin": got["spin"]}


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.pico", description=__doc__.split("\n")[0])
    p.add_argument("--window", type=float, default=10.0,
                   help="emulated seconds each window lasts (default 10: two provisional solves)")
    p.add_argument("--frozen", action="store_true",
                   help="the image with the firmware frozen in (make pico-frozen) instead of .mpy files")
    p.add_argument("--status-every", type=float, default=SAMPLE_S, metavar="S",
                   help="board seconds between the status samples in a window (default %(default)s; past the"
                        " window: none, and no lowest heap sample)")
    args = p.parse_args(argv)
    t0 = time.time()

    def log(msg):
        print("[%4.0f s] %s" % (time.time() - t0, msg), file=sys.stderr, flush=True)
    m3 = {}
    # the Cortex-M3 counts (qemu, deterministic) meanwhile: they share the cores, not the figures
    counting = threading.Thread(target=lambda: m3.update(pico_compare.m3_counts()), daemon=True)
    counting.start()
    pico = pico_run(args.window, log, args.frozen, args.status_every)
    mp = micropython_spin(args.window, log)
    counting.join()
    pico_compare.print_tables(pico, mp, m3.get("firmware"))
    options = (" --frozen" if args.frozen else "") + (
        "" if args.status_every == SAMPLE_S else " --status-every %g" % args.status_every)
    print("\n(command: python -m desktop.bench.pico --window %g%s; %.0f s; host load average %.1f: the wall"
          " figures scale with it, the cycle figures do not)" % (args.window, options, time.time() - t0,
                                                               os.getloadavg()[0]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
