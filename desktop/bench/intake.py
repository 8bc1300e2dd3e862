"""How fast the firmware throws away junk on its serial line, and answers what follows it.

    python -m desktop.bench.intake                       # 1 MB on every runtime built here
    python -m desktop.bench.intake --bytes 100000 --runtime micropython

A file sent to the wrong port, a misconfigured tool: bytes without a newline pour in, and a
request behind them waits until the firmware has read past them. On the virtual handheld (the
firmware through its own HAL, on the runtime's interpreter, in real time) this sends `status`,
then NBYTES of junk (letters, no newline) and `\\nstatus\\n`, and reads the two replies. The
firmware's own clock (`uptime_ms`, chip time) between them gives the rate of its intake, a
property of the firmware (bytes read per main-loop pass, passes per second) however busy this
machine is; the wall time is printed beside it. The acquisition's loss counters (missed
conversions, ring overflows, discarded blocks, gaps) must not move meanwhile, and the junk must
cost exactly one `line_too_long` error.
"""

import argparse
import json
import os
import tempfile
import threading
import time

import serial

from desktop.devicesim.runners import install_firmware
from desktop.devicesim.virtual_handheld import RUNTIMES, VirtualHandheld
from desktop.firmware.files import import_device
from desktop.firmware.interpreters import interpreter
from shared import codes

LOSSES = ("missed", "overflow", "discarded", "gaps")
_JUNK = b"the wrong file sent to the handheld's port "     # no newline: one line, too long


def _lines(ser, until, deadline, seen):
    """Lines from the device until one satisfies `until`; every line also goes to seen."""
    buf = b""
    while time.monotonic() < deadline:
        buf += ser.read(ser.in_waiting or 1)
        while b"\n" in buf:
            raw, buf = buf.split(b"\n", 1)
            try:
                msg = json.loads(raw)
            except ValueError:
                continue
            seen.append(msg)
            if until(msg):
                return msg
    raise TimeoutError("no reply by the deadline; last lines: %s" % seen[-3:])


def _is_status(msg):
    return msg.get("cmd") == "status" and msg.get("ok")


def junk_then_status(port, nbytes, timeout=600.0):
    """Send status, nbytes of junk, status; {"bytes", "chip_s", "wall_s", "too_long", "before",
    "after"}: chip_s the firmware's uptime between its two status replies."""
    deadline = time.monotonic() + timeout
    seen = []
    with serial.Serial(port, timeout=0.1, exclusive=True) as ser:
        ser.reset_input_buffer()
        ser.write(b"status\n")
        before = _lines(ser, _is_status, deadline, seen)
        junk = (_JUNK * (nbytes // len(_JUNK) + 1))[:nbytes]
        seen.clear()
        t0 = time.monotonic()

        def write():        # blocks while the line is full: as fast as the firmware reads
            for i in range(0, nbytes, 4096):
                ser.write(junk[i:i + 4096])
            ser.write(b"\nstatus\n")
        writer = threading.Thread(target=write, daemon=True)
        writer.start()
        after = _lines(ser, _is_status, deadline, seen)
        wall = time.monotonic() - t0
        writer.join(timeout=10)
    too_long = sum(1 for m in seen if m.get("error") == codes.LINE_TOO_LONG)
    return {"bytes": nbytes, "chip_s": (after["uptime_ms"] - before["uptime_ms"]) / 1000.0, "wall_s": wall,
            "too_long": too_long, "before": before, "after": after}


def on_handheld(runtime, nbytes, timeout=600.0):
    """junk_then_status on a fresh virtual handheld of the runtime, booted into the firmware."""
    with tempfile.TemporaryDirectory(prefix="fluxcal-intake-") as tmp:
        flash = os.path.join(tmp, "flash")
        os.makedirs(flash)
        hh = VirtualHandheld(flash, runtime=runtime)
        install_firmware(flash, hh.runtime)
        import_device("store").save(flash, "config", hh.wiring_config())
        with hh:
            _await_boot(hh.port)
            return junk_then_status(hh.port, nbytes, timeout)


def _await_boot(port, wait_s=60.0):
    deadline = time.monotonic() + wait_s
    with serial.Serial(port, timeout=0.1, exclusive=True) as ser:
        _lines(ser, lambda m: m.get("ev") == codes.EV_BOOT, deadline, [])


def losses(r):
    """{counter: increase} of the acquisition's loss counters between the two replies."""
    return {k: r["after"][k] - r["before"][k] for k in LOSSES}


def main():
    p = argparse.ArgumentParser(prog="python -m desktop.bench.intake", description=__doc__.splitlines()[0])
    p.add_argument("--bytes", type=int, default=1_000_000, help="junk bytes (default 1 MB)")
    p.add_argument("--runtime", choices=RUNTIMES, action="append", help="(default: every one built here)")
    args = p.parse_args()
    runtimes = args.runtime or [r for r in RUNTIMES if interpreter(r) is not None]
    print("%d bytes of junk, then status, on the virtual handheld\n" % args.bytes)
    print("| runtime | answered after (chip s) | intake (kB/s, chip time) | wall s | line_too_long | losses |")
    print("|---|---|---|---|---|---|")
    for runtime in runtimes:
        r = on_handheld(runtime, args.bytes)
        lost = losses(r)
        print("| %s | %.1f | %.0f | %.1f | %d | %s |" % (runtime, r["chip_s"], r["bytes"] / r["chip_s"] / 1000.0,
                                                      r["wall_s"], r["too_long"],
                                                      ", ".join("%s %d" % kv for kv in lost.items() if kv[1])
                                                      or "none"), flush=True)


if __name__ == "__main__":
    main()
