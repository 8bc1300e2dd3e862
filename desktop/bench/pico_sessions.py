"""Calibration sessions in a row on the emulated Raspberry Pi Pico, without a reboot: each refused or not.

    python -m desktop.bench.pico_sessions [--runs 3] [--mhz 125] [--frozen]   # ~2-3 wall min a run

What: the firmware as `fluxcal deploy` puts it on the emulated Pico (`.mpy` in the heap; --frozen:
the image with the firmware frozen in), a hand calibration and a survey spin with the stream on
(pico_session.Session, 6 emulated s each), then, with the operator following the LED for 6 s
after each start: start-cal quick, finish-cal, start-cal, cancel-cal, start-cal quick, finish-cal,
start-cal, finish-cal. A session imports its modules and allocates its buffers again each time, in
a heap the survey and the last session left in pieces; on a Pico's `.mpy` firmware that is where
a start-cal can be refused `no_memory` (calibration_flow.py start). Per run: each step's answer
(ok, or the refusal's code), and the ring's overflows at the end (the finish's stretches).
The hand motion's timing follows the host's, so runs differ: hence several.
"""

import argparse
import os
import shutil
import sys
import tempfile
import time

from desktop.bench import power
from desktop.bench.pico import Runner
from desktop.bench.pico_session import Session
from desktop.devicesim.pico_handheld import PicoHandheld

STEPS = ("start-cal quick", "finish-cal", "start-cal", "cancel-cal", "start-cal quick", "finish-cal",
         "start-cal", "finish-cal")
FOLLOW_S = 6.0     # emulated s the operator follows the LED after each start


def one_run(flash, mhz, frozen, log):
    """[(step, "ok ..." or the refusal's code)], the ring's overflows at the end."""
    from desktop.firmware.deploy import firmware_version
    from desktop.link import DeviceError, open_device, wait_for_version

    out = []
    with tempfile.TemporaryDirectory(prefix="fluxcal-pico-sessions-") as tmp:
        shutil.copy(flash, os.path.join(tmp, "pico.flash"))
        with PicoHandheld(tmp, idle="jump", frozen=frozen) as hh:
            wait_for_version(hh.port, firmware_version("micropython"), wait_s=300.0)
            dev = open_device(hh.port, timeout=120)
            dev = power._start_at(hh, dev, mhz * 1000000)
            runner = Runner(hh.board)
            got = Session(dev, runner.clock, hh.act, runner.figures).run(6.0)
            out.append(("hand calibration, survey", "ok, %s" % got["result"].get("state")))
            refused = False
            for step in STEPS:
                if refused and not step.startswith("start"):
                    out.append((step, "-"))
                    continue
                try:
                    reply = dev.ask(step, timeout=300)
                except DeviceError as e:
                    out.append((step, "refused: %s" % e.code))
                    refused = True
                    continue
                refused = False
                result = reply.get("result") or {}
                out.append((step, "ok" + (", %s %s" % (result.get("state"), result.get("kind") or result.get("reason") or "")
                                          if result else "")))
                if step.startswith("start"):
                    hh.act("follow")
                    end = runner.clock() + FOLLOW_S
                    while runner.clock() < end:
                        time.sleep(0.2)
            overflow = dev.ask("status", timeout=120)["overflow"]
            dev.close()
    log("run: %s" % "; ".join("%s %s" % s for s in out))
    return out, overflow


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.pico_sessions", description=__doc__.split("\n")[0])
    p.add_argument("--runs", type=int, default=3, help="runs, each from the same deployed flash (default 3)")
    p.add_argument("--mhz", type=int, default=125, help="clk_sys, MHz (default 125)")
    p.add_argument("--frozen", action="store_true", help="the image with the firmware frozen in (make pico-frozen)")
    args = p.parse_args(argv)
    t0 = time.time()

    def log(msg):
        print("[%4.0f s] %s" % (time.time() - t0, msg), file=sys.stderr, flush=True)
    with tempfile.TemporaryDirectory(prefix="fluxcal-pico-sessions-base-") as base:
        flash = power.deployed_flash(base, log, args.frozen)
        runs = [one_run(flash, args.mhz, args.frozen, log) for _ in range(args.runs)]
    steps = [s for s, _ in runs[0][0]]
    print("| step | %s |" % " | ".join("run %d" % (k + 1) for k in range(len(runs))))
    print("|---|%s" % ("---|" * len(runs)))
    for i, step in enumerate(steps):
        print("| %s | %s |" % (step, " | ".join(r[0][i][1] for r in runs)))
    print("| ring overflows at the end | %s |" % " | ".join(str(r[1]) for r in runs))
    print("\n(command: python -m desktop.bench.pico_sessions --runs %d --mhz %d%s; %.0f s)" % (
        args.runs, args.mhz, " --frozen" if args.frozen else "", time.time() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
