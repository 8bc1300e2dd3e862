"""The virtual handheld from a laptop: real time, start-up, deploy, calibration, latency.

    python -m desktop.bench.handheld               # markdown table (README)
    python -m desktop.bench.handheld --repeats 3

What, per runtime (the interpreters a board has, and the firmware in CPython), at the
default acquisition configuration, wall time on this shared machine, median (min-max)
over the runs:
- start-up: `fluxcal emulate` launched until the firmware answers `version` on its port, first
  with an empty flash (emulate deploys to it: fluxcal deploy's code over mpremote), then again
  with the firmware on the flash;
- deploy: `fluxcal deploy` (.mpy and source) into `fluxcal emulate --bare`, until the
  firmware it installed answers (MicroPython runtimes; CircuitPython takes a drive folder);
- calibrate: `fluxcal calibrate --auto` against it, the virtual operator following the LED,
  until the result is printed;
- capacity: simulated seconds the firmware serves per wall second it runs (above 1: it keeps
  up with real time), calibrating and in survey (desktop/devicesim/realtime.py);
- latency: a 100 nT field step in the simulated world (action field-step) to the first
  streamed block that shows it, on the protocol stream `fluxcal monitor` reads (the world
  passes the step's time at wall time W; the block is read from the pty at W + latency).
Why: the issue's promise is that a person without hardware can work with it live; these say
how live, and where a slow machine would show it.
"""

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

import serial

from desktop.bench.repeat import fmt
from desktop.devicesim.runners import install_firmware
from desktop.devicesim.virtual_handheld import RUNTIMES, VirtualHandheld
from desktop.firmware.files import import_device
from desktop.firmware.interpreters import interpreter

FLUXCAL = [os.path.join(os.path.dirname(sys.executable), "fluxcal")]   # as a user runs it
ALL = RUNTIMES + ("cpython",)


def _emulate(runtime, *extra):
    """`fluxcal emulate` in a subprocess, once it says it is ready (it may deploy first); (process, port)."""
    proc = subprocess.Popen(FLUXCAL + ["emulate", "--runtime", runtime] + list(extra), stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    line = proc.stdout.readline()
    m = re.search(r" on (/dev/\S+)", line)
    while m and not line.startswith("ready") and proc.poll() is None:
        line = proc.stdout.readline()
    if not m or not line.startswith("ready"):
        proc.kill()
        raise RuntimeError("fluxcal emulate: %s%s" % (line, proc.stdout.read()[-1000:]))
    return proc, m.group(1)


def _answers(port, timeout=30.0):
    """Seconds until the firmware on `port` answers `version` (None: it did not)."""
    t0 = time.monotonic()
    with serial.Serial(port, timeout=0.1) as ser:
        while time.monotonic() - t0 < timeout:
            ser.write(b"\nversion\n")
            buf = b""
            end = time.monotonic() + 0.5
            while time.monotonic() < end:
                buf += ser.read(4096)
                if b'"cmd": "version"' in buf:
                    return time.monotonic() - t0
    return None


def startup(runtime):
    """(s from launch until the firmware answers with an empty flash, which emulate deploys to
    first; the same with the flash already holding the firmware). cpython: no flash (None, s)."""
    with tempfile.TemporaryDirectory() as tmp:
        flash = os.path.join(tmp, "flash")
        out = []
        for _ in range(2):
            t0 = time.monotonic()
            proc, port = _emulate(runtime, "--flash", flash)
            try:
                answered = _answers(port)
                out.append(None if answered is None else time.monotonic() - t0)
            finally:
                proc.terminate()
                proc.wait(timeout=10)
        return (None, out[1]) if runtime == "cpython" else tuple(out)


def deploy(runtime, how):
    proc, port = _emulate(runtime, "--bare")
    try:
        t0 = time.monotonic()
        r = subprocess.run(FLUXCAL + ["deploy", "--port", port, how], capture_output=True, text=True, timeout=600)
        if r.returncode:
            raise RuntimeError("fluxcal deploy %s: %s" % (how, (r.stderr or r.stdout).strip()[-500:]))
        return time.monotonic() - t0
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def calibrate(runtime):
    """Seconds of `fluxcal calibrate --auto`, and the capacities emulate printed meanwhile."""
    proc, port = _emulate(runtime)
    try:
        if _answers(port) is None:
            raise RuntimeError("%s: the firmware did not answer" % runtime)
        t0 = time.monotonic()
        r = subprocess.run(FLUXCAL + ["calibrate", "--auto", "--port", port], capture_output=True, text=True,
                           timeout=300)
        took = time.monotonic() - t0
        if r.returncode:
            raise RuntimeError("fluxcal calibrate: %s" % (r.stderr or r.stdout).strip()[-500:])
        return took
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def capacity_and_latency(runtime, seconds=12.0):
    """(capacity calibrating, capacity in survey, field-step latency s) on a VirtualHandheld."""
    with tempfile.TemporaryDirectory() as tmp:
        flash = os.path.join(tmp, "flash")
        os.makedirs(flash)
        hh = VirtualHandheld(flash, runtime=runtime, seed=1)
        install_firmware(flash, hh.runtime)
        import_device("store").save(flash, "config", hh.wiring_config())
        with hh, serial.Serial(hh.port, timeout=0.05) as ser:
            _read_for(ser, 1.0)
            ser.write(b"\nstart-cal\n")
            _read_for(ser, seconds, stop=b'"state": "done"')
            cal_cap = hh.pacer.capacity
            ser.write(b"\nstream on corrected\n")
            _read_for(ser, 6.0)
            survey_cap = hh.pacer.capacity
            latency = _step_latency(hh, ser)
    return cal_cap, survey_cap, latency


def _read_for(ser, seconds, stop=None):
    buf = b""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        buf += ser.read(65536)
        if stop is not None and stop in buf:
            break
    return buf


def _step_latency(hh, ser, nT=100.0):
    """Wall seconds from the world reaching a field step to the first data event showing it."""
    base = []
    buf = b""
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        buf += ser.read(65536)
        *lines, buf = buf.split(b"\n")
        base += [json.loads(ln)["f"] for ln in lines if b'"ev": "data"' in ln]
    if not base:
        return None
    level = sum(base) / len(base)
    hh.act("field-step", str(nT))
    end = time.monotonic() + 5.0
    while time.monotonic() < end:
        buf += ser.read(65536)
        *lines, buf = buf.split(b"\n")
        for ln in lines:
            if b'"ev": "data"' in ln and json.loads(ln)["f"] > level + 0.5 * nT and hh.hands.steps_reached:
                return time.monotonic() - hh.hands.steps_reached[0]
    return None


def _measured(row, runtime, what, fn, *args):
    """fn(*args), or None with the failure kept for the table's notes (a loaded machine can
    make the virtual handheld fall behind real time: emulate then stops, as it should)."""
    try:
        return fn(*args)
    except (RuntimeError, subprocess.TimeoutExpired) as exc:
        row["failed"].append((what, str(exc).strip().splitlines()[-1][:200]))
        print("%s %s: %s" % (runtime, what, exc), file=sys.stderr)
        return None


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.handheld", description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--runtime", action="append", choices=ALL, help="only these runtimes (repeatable; default all)")
    args = p.parse_args(argv)
    t0 = time.time()
    rows = {}
    for name in args.runtime or ALL:
        if name != "cpython" and interpreter(name) is None:
            continue
        r = rows[name] = {"first": [], "again": [], "mpy": [], "source": [], "calibrate": [], "cap_cal": [],
                          "cap_survey": [], "latency": [], "failed": []}
        for _ in range(args.repeats):
            first, again = _measured(r, name, "start-up", startup, name) or (None, None)
            r["first"].append(first)
            r["again"].append(again)
            if name != "cpython" and name != "circuitpython":
                r["mpy"].append(_measured(r, name, "deploy --mpy", deploy, name, "--mpy"))
                r["source"].append(_measured(r, name, "deploy --source", deploy, name, "--source"))
            r["calibrate"].append(_measured(r, name, "calibrate", calibrate, name))
            if name != "cpython":
                cal, survey, latency = _measured(r, name, "capacity", capacity_and_latency, name) or (None,) * 3
                r["cap_cal"].append(cal)
                r["cap_survey"].append(survey)
                r["latency"].append(latency)
    print("### The virtual handheld from a laptop (wall time on this machine, median (min-max) over %d runs)\n"
          % args.repeats)
    print("| runtime | emulate to answering: empty flash (deploys) / deployed | deploy .mpy | deploy source |"
          " calibrate --auto (LED-following operator) | capacity calibrating | capacity survey |"
          " field step to the stream |")
    print("|---|---|---|---|---|---|---|---|")

    def cell(values, f, unit):
        values = [v for v in values if v is not None]
        return fmt(values, f, unit) if values else "-"
    for name, r in rows.items():
        print("| %s | %s / %s | %s | %s | %s | %s | %s | %s |" % (
            name, cell(r["first"], "%.1f", " s"), cell(r["again"], "%.1f", " s"), cell(r["mpy"], "%.1f", " s"), cell(r["source"], "%.1f", " s"),
            cell(r["calibrate"], "%.1f", " s"), cell(r["cap_cal"], "%.1f", "x"), cell(r["cap_survey"], "%.1f", "x"),
            cell(r["latency"], "%.2f", " s")))
    for name, r in rows.items():
        for what, why in r["failed"]:
            print("\n%s, %s failed: %s" % (name, what, why))
    print("\n(command: python -m desktop.bench.handheld --repeats %d; %.0f s)" % (args.repeats, time.time() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
