"""The long survey run: hours of simulated survey on the real `micropython`, faster than real time.

    python -m desktop.bench.longrun --hours 8              # the table of docs/long-run.md
    python -m desktop.bench.longrun --minutes 5 --every 10
    python -m desktop.bench.longrun --hours 0.1 --profile host.prof   # cProfile of the host side

The firmware's "sim" image runs in the `micropython` executable (desktop/devicesim/runners.py,
kind "micropython") on the default config, its serial line a real pseudo-terminal read by the
harness's client (desktop/devicesim/client.py). A still sensor in the default field (Mag649,
seed 3), its analog input computed as time goes (Handheld `chunked`). After boot the client
installs a calibration (set-cal with the sensor's own correction in codes, what a perfect fit
would give), switches logging on (`config set log true`: rotating CSV files on the flash
folder) and the corrected stream (`stream corrected`), then asks `status` every `--every`
simulated seconds and counts every `data` event by the simulated minute it carries.

What it checks and prints (a markdown table):
- heap: `mem_free` after warm-up, the first and the last hour's (or the run's first and last
  tenth's) min and max: a leak shows as a last-hour floor below the first hour's;
- frames: the firmware's frame counter against the DRDY edges the World delivered between
  two status replies (continuous: equal, none merged), missed == 0, overflow == 0, and every
  frame accounted for: frames // decim - (samples + overflow + discarded) is the open
  block and what waits in the ring (0..2 at a status);
- output rate: data events per simulated minute, min and max over the complete minutes
  (the stream's survey_hz x 60);
- logs: the log files' count and total bytes on the flash folder at every status, against
  log_files and log_files x log_file_bytes.

`run(seconds, ...)` returns the figures as a dict; longrun_report.py's `problems(figures)`
the invariants that failed, `table(figures)` the markdown; tests/test_long_run.py runs a
few minutes through them.
"""

import argparse
import cProfile
import json
import os
import pstats
import sys
import tempfile
import time

import numpy as np
import serial

from desktop.bench.longrun_report import problems, table
from desktop.devicesim.client import Client
from desktop.devicesim.runners import start_device
from desktop.devicesim.world import make_world
from desktop.firmware.files import import_device

CONFIG = import_device("config")
DEFAULTS = CONFIG.defaults()
# the sim HAL's ticks_ms is the World's microsecond clock (wrapped at sim_wire.T_MASK + 1) over
# 1000: the `t` of the events comes round every 1,073,741.824 ms (17.9 simulated minutes)
TICKS_PERIOD_MS = (import_device("sim_wire").T_MASK + 1) / 1000.0
WARM_UP_S = 60.0      # heap figures start after this much survey
# status every 15 simulated seconds: ~240 samples an hour of the heap's sawtooth (a collection
# every ~10 s) put an hour's max within ~0.5 KB of the ceiling; each costs two pty hand-overs
EVERY_S = 15.0
# the client reads the pty every STEP_S of simulated time at the most: each read waits for
# the pty to hand the bytes over; the pty holds ~20 KB and the stream writes ~1.7 KB a
# simulated second (what does not fit waits in the World, tried again every 2 ms)
STEP_S = 10.0


def calibration_record(scenario, sensor):
    """The sensor's own correction in ADC codes: h_c = M (codes - b) with M symmetric
    ((A A^T)^-1/2 times the nominal nT per code, A the sensor's raw-model matrix) and b its
    offset in codes: what a perfect ellipsoid fit would install."""
    a, c = sensor.raw_model()                 # raw nT (nominal scale) = A b + c
    k = scenario.nt_per_code()
    w, v = np.linalg.eigh(a @ a.T)
    m = (v / np.sqrt(w)) @ v.T                # (A A^T)^-1/2: |m (raw - c)| = |b|
    return {"matrix": (m * k[None, :]).tolist(), "offset": (c / k).tolist(), "field": float(scenario.field_nT),
            "meta": {"temperature_c": float(scenario.temp_c), "source": "longrun"}}


def _child_cpu_s(proc):
    """CPU seconds (user + system) of a child process so far, from /proc; None elsewhere."""
    try:
        with open("/proc/%d/stat" % proc.pid) as f:
            v = f.read().rsplit(")", 1)[1].split()
        return (int(v[11]) + int(v[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def _log_files(flash):
    names = [n for n in os.listdir(flash) if n.startswith("log") and n.endswith(".csv")]
    return len(names), sum(os.path.getsize(os.path.join(flash, n)) for n in names)


class LongRun:
    """One survey run: start(), then advance(t) to simulated time t, then close().

    seconds: how long the scenario (the sensor's story) lasts; the run may stop earlier.
    """

    def __init__(self, seconds, root, kind="micropython", every_s=EVERY_S, seed=3, settings=None, pin=True):
        self.seconds, self.root, self.kind, self.every_s = float(seconds), root, kind, float(every_s)
        self.pin = pin
        self.settings = dict(settings or {})     # config keys set before logging starts
        self.cfg = dict(DEFAULTS, **self.settings)
        self.world = make_world(serial="pty", motion="stationary", seconds=self.seconds + 10.0, seed=seed,
                                rate=DEFAULTS["rate"], grid_rate=8000, chunked=True)
        self.flash = os.path.join(root, "flash")
        self.statuses = []      # (status reply, host snapshot at the moment the firmware wrote it)
        self.per_minute = {}    # simulated minute -> data events stamped in it
        self._t_last, self._t_wraps = None, 0
        self.data_events = 0
        self.bad_data = 0       # data events not calibrated or far from the field
        self.other_events = []
        self._snap = None
        self.dev = self.ser = self.client = None
        self.t_setup = None

    # ****** the host's view at the moment the firmware answers `status` ******
    def _watch_serial(self):
        w = self.world
        write = w.serial_write

        def serial_write(data):
            if b'"frames"' in data:
                self._snap = {"t": w.time, "edges": w.drdy_edges, "merged": w.drdy_merged,
                              "conversions": w.chips[0].conversions}
            write(data)
        w.serial_write = serial_write

    def start(self):
        w = self.world
        self._watch_serial()
        self.dev = start_device(w, self.root, kind=self.kind)
        self._pin()
        self.dev.run_until(0.5)
        self.ser = serial.Serial(w.serial_port, baudrate=115200, timeout=5, exclusive=True)
        self.client = c = Client(self.ser, self.dev)
        cal = calibration_record(w.scenario, w.handheld.sensor)
        lines = ["config set %s %s" % (k, json.dumps(v)) for k, v in self.settings.items()]
        for line in ["set-cal " + json.dumps(cal)] + lines + ["config set log true", "stream corrected"]:
            r = c.ask(line)
            if not r.get("ok"):
                raise RuntimeError("%s: %s" % (line.split()[0], r))
        self.t_setup = w.time
        self._take()
        self.sample_status()
        self._cpu0 = (time.monotonic(), time.process_time(), _child_cpu_s(getattr(self.dev, "proc", None)))

    def cpu(self):
        """(wall s, host CPU s, firmware process CPU s or None) since the survey began."""
        wall, host, child = self._cpu0
        now = _child_cpu_s(getattr(self.dev, "proc", None))
        return (time.monotonic() - wall, time.process_time() - host,
                None if now is None or child is None else now - child)

    def _take(self):
        """Count what the client read so far and forget it (hours of stream would not fit)."""
        field = self.world.scenario.field_nT
        for d in self.client.seen:
            if d.get("ev") == "data":
                self.data_events += 1
                t = d["t"]
                if self._t_last is not None and t < self._t_last - TICKS_PERIOD_MS / 2:
                    self._t_wraps += 1          # the ms clock came round (unwrapped here)
                self._t_last = t
                minute = int((t + self._t_wraps * TICKS_PERIOD_MS) // 60000)
                self.per_minute[minute] = self.per_minute.get(minute, 0) + 1
                if not d.get("cal") or abs(d["f"] - field) > 50.0:
                    self.bad_data += 1
            elif "ev" in d:
                self.other_events.append(d)
        self.client.seen.clear()

    def sample_status(self):
        self._snap = None
        r = self.client.ask("status")
        self._take()
        n, size = _log_files(self.flash)
        self.statuses.append((r, dict(self._snap or {}, log_files=n, log_bytes=size)))
        return r

    def advance(self, t):
        """Run to simulated time t, asking status every every_s."""
        w, c = self.world, self.client
        next_status = self.statuses[-1][1].get("t", w.time) + self.every_s
        while w.time < t:
            c.step(max(min(STEP_S, t - w.time, next_status - w.time), 0.001))
            self._take()
            if w.time >= next_status:
                self.sample_status()
                next_status += self.every_s

    def _pin(self):
        """The harness and the firmware's process on one CPU: they take turns (the firmware
        waits for every reply), so a hand-over is a switch on one run queue, not a wake-up
        across CPUs (on this 2-core machine ~25 % faster, and steadier, under load)."""
        proc = getattr(self.dev, "proc", None)
        self._affinity = None
        if not self.pin or proc is None or not hasattr(os, "sched_setaffinity"):
            return
        self._affinity = os.sched_getaffinity(0)
        cpu = {max(self._affinity)}
        os.sched_setaffinity(proc.pid, cpu)
        os.sched_setaffinity(0, cpu)

    def close(self):
        if getattr(self, "_affinity", None):
            os.sched_setaffinity(0, self._affinity)
        if self.ser is not None:
            self.ser.close()
        if self.dev is not None:
            self.dev.close()

    # ****** the figures ******
    def figures(self):
        st = [(r, s) for r, s in self.statuses if r.get("ok")]
        first_t = st[0][1]["t"]
        end_t = st[-1][1]["t"]
        span = end_t - first_t
        # heap windows: first and last hour, or first and last third of a shorter run, after warm-up
        win = 3600.0 if span >= 2 * 3600.0 + WARM_UP_S else max((span - WARM_UP_S) / 3.0, self.every_s)
        mem = [(s["t"], r["mem_free"]) for r, s in st if "mem_free" in r and s["t"] >= first_t + WARM_UP_S]
        heap_first = [m for t, m in mem if t < first_t + WARM_UP_S + win]
        heap_last = [m for t, m in mem if t >= end_t - win]
        hourly = {}             # the ceiling hour by hour, after warm-up
        for t, m in mem:
            h = int((t - first_t - WARM_UP_S) // 3600)
            hourly[h] = max(hourly.get(h, 0), m)
        # frame counter against the DRDY edges delivered between consecutive replies
        jumps = []
        for (r0, s0), (r1, s1) in zip(st, st[1:]):
            if "edges" in s0 and "edges" in s1:
                jumps.append((r1["frames"] - r0["frames"], s1["edges"] - s0["edges"],
                              s1["conversions"] - s0["conversions"]))
        decim = self.cfg["decim"]
        unaccounted = [r["frames"] // decim - (r["samples"] + r["overflow"] + r["discarded"]) for r, _ in st]
        t0_min, t1_min = int(first_t // 60) + 1, int(end_t // 60) - 1   # complete minutes only
        minutes = [self.per_minute.get(m, 0) for m in range(t0_min, t1_min + 1)]
        last = st[-1][0]
        return {
            "simulated_s": span, "statuses": len(st), "every_s": self.every_s, "warm_up_s": WARM_UP_S,
            "heap_first": (min(heap_first), max(heap_first)) if heap_first else None,
            "heap_last": (min(heap_last), max(heap_last)) if heap_last else None,
            "heap_window_s": win, "heap_hourly_max": [hourly[h] for h in sorted(hourly)] if span > 7200 else [],
            "tick_wraps": self._t_wraps,
            "frames": last["frames"], "samples": last["samples"], "missed": last["missed"],
            "overflow": last["overflow"], "badsync": last["badsync"], "discarded": last["discarded"],
            "gaps": last["gaps"],
            "frame_jumps": len(jumps),
            "frames_vs_edges": sum(1 for f, e, _ in jumps if f != e),
            "edges_vs_conversions": sum(1 for _, e, c in jumps if e != c),
            "merged_edges": st[-1][1].get("merged", 0),
            "unaccounted": (min(unaccounted), max(unaccounted)),
            "per_minute": (min(minutes), max(minutes)) if minutes else None,
            "minutes": len(minutes), "expected_per_minute": 60 * self.cfg["survey_hz"],
            "data_events": self.data_events, "bad_data": self.bad_data,
            "log_files_max": max(s["log_files"] for _, s in st),
            "log_bytes_max": max(s["log_bytes"] for _, s in st),
            "log_files_allowed": self.cfg["log_files"],
            "log_bytes_allowed": self.cfg["log_files"] * self.cfg["log_file_bytes"],
            "settings": self.settings,
            "log_lines": (last.get("log") or {}).get("lines"), "log_error": (last.get("log") or {}).get("error"),
            "events": sorted({d["ev"] for d in self.other_events}),
            "state": last.get("state"), "fault": last.get("fault"),
        }


def run(seconds, root=None, kind="micropython", every_s=EVERY_S, seed=3, settings=None, pin=True, progress=None):
    """Run a survey of `seconds` simulated seconds; the figures (dict, see `problems`) with
    the wall time ("wall_s") and the simulated over wall speed-up ("speed"). settings:
    config keys to set before logging starts (the default config otherwise)."""
    with tempfile.TemporaryDirectory() as tmp:
        lr = LongRun(seconds, root or tmp, kind=kind, every_s=every_s, seed=seed, settings=settings, pin=pin)
        t_wall = time.monotonic()
        try:
            lr.start()
            end = lr.t_setup + seconds
            while lr.world.time < end:
                lr.advance(min(end, lr.world.time + max(every_s, 600.0)))
                if progress is not None:
                    progress(lr.world.time - lr.t_setup, time.monotonic() - t_wall)
            lr.sample_status()              # the end of the run: the last figures
            survey_wall, host_cpu, fw_cpu = lr.cpu()
            figs = lr.figures()
        finally:
            lr.close()
        figs["wall_s"] = time.monotonic() - t_wall
        figs["survey_wall_s"], figs["host_cpu_s"], figs["firmware_cpu_s"] = survey_wall, host_cpu, fw_cpu
        figs["speed"] = figs["simulated_s"] / survey_wall
        return figs


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.longrun", description=__doc__.split("\n\n")[0])
    p.add_argument("--hours", type=float, default=None)
    p.add_argument("--minutes", type=float, default=None)
    p.add_argument("--every", type=float, default=EVERY_S, help="simulated seconds between status requests")
    p.add_argument("--kind", default="micropython", help="runner: micropython (default), cpython, ...")
    p.add_argument("--seed", type=int, default=3)
    p.add_argument("--profile", metavar="FILE", help="cProfile the host side into FILE, print the top")
    p.add_argument("--no-pin", action="store_true", help="leave both processes to the scheduler (default: one CPU)")
    args = p.parse_args(argv)
    seconds = 3600.0 * (args.hours if args.hours is not None else 8.0 if args.minutes is None else 0.0) \
        + 60.0 * (args.minutes or 0.0)

    def progress(sim, wall):
        print("  %.2f h simulated in %.0f s wall (%.1fx)" % (sim / 3600, wall, sim / max(wall, 1e-9)),
              file=sys.stderr, flush=True)

    prof = cProfile.Profile() if args.profile else None
    if prof:
        prof.enable()
    figs = run(seconds, kind=args.kind, every_s=args.every, seed=args.seed, pin=not args.no_pin, progress=progress)
    if prof:
        prof.disable()
        prof.dump_stats(args.profile)
        pstats.Stats(prof, stream=sys.stderr).sort_stats("tottime").print_stats(25)
    print(table(figs))
    bad = problems(figs)
    print()
    print("(command: python -m desktop.bench.longrun %s; %.0f s wall)" % (" ".join(argv or sys.argv[1:]), figs["wall_s"]))
    if bad:
        print("INVARIANTS FAILED:\n" + "\n".join("- " + b for b in bad))
        return 1
    print("all invariants held")
    return 0


if __name__ == "__main__":
    sys.exit(main())
