"""fluxcal calibrate [--quick|--full] [--auto]: run a calibration on the handheld, watched and steered from the laptop.

Starts a session (`start-cal`), shows the firmware's progress (`cal` events,
once a second) and the coverage of the sphere (`get-coverage`), and ends it:
f or Enter finishes (`finish-cal`), c, q or Esc cancels (`cancel-cal`, also on
Ctrl-C). The firmware finishes by itself once coverage and predicted error
suffice (config auto_finish); --auto waits for that, sending finish-cal itself
at `ready` when the device's auto_finish is off. Prints the result, its
figures and the calibration it replaced; a failed or cancelled calibration
leaves the previous one in force and exits 1.
"""

import sys
import time

from desktop.cli._errors import CommandError
from desktop.cli._device import add_port_arguments, connected, device_config, quietly, stream_events
from shared import codes

HELP = "calibrate the handheld: live progress and coverage map, finish or cancel from the keyboard"
SILENCE_S = 5.0     # the firmware sends progress every second; this long without is a dead device


def add_arguments(p):
    kind = p.add_mutually_exclusive_group()
    kind.add_argument("--quick", action="store_true",
                      help="a quick re-calibration: keep the shape of the calibration in force, re-fit its "
                           "offsets and gains from a partial turn (wrist twists, 10-30 %% of the sphere)")
    kind.add_argument("--full", action="store_true",
                      help="a full calibration even when the coverage stays partial (default: the firmware "
                           "ends quick when a calibration is in force and the coverage is partial)")
    p.add_argument("--auto", action="store_true",
                   help="take no keys: wait until the firmware finishes by itself (coverage and error reached)")
    p.add_argument("--verify", type=float, default=0.0, metavar="S",
                   help="afterwards, S seconds of corrected |B| while you keep turning: its peak-to-peak and std")
    add_port_arguments(p)


def run(args):
    from desktop.cli._calibrate_view import Keys, Lines, Board
    from desktop.cli._show import calibration_lines, coverage_text, fit_figures

    with connected(args) as dev:
        cfg = device_config(dev)
        previous = dev.ask("get-cal")["cal"]
        status = dev.ask("status")
        dev.ask("start-cal quick" if args.quick else "start-cal full" if args.full else "start-cal")
        try:
            view = Board(cfg, args.auto) if sys.stdout.isatty() else Lines(cfg)
            with view, Keys(enabled=not args.auto) as keys:
                result = _follow(dev, cfg, args.auto, view, keys)
        except BaseException:
            quietly(dev, "cancel-cal")     # leave no session running; a dead line is no news
            raise
        cov = dev.ask("get-coverage")
        verify = _verify(dev, args.verify, cfg) if result.get("state") == codes.DONE and args.verify > 0 else None
    if not sys.stdout.isatty():
        print("\n".join(coverage_text(cov["counts"], cov["cells_per_edge"], cfg["cell_cap"])))
    if result.get("state") == codes.CANCELLED:
        raise CommandError("calibration cancelled; the previous calibration stays in force")
    if result.get("state") != codes.DONE:
        raise CommandError("calibration failed (%s): %s; the previous calibration stays in force"
                           % (result.get("reason"), result.get("msg")))
    print("calibration done: %s; %s; %s" % (fit_figures(result),
                                            "saved, in force" if result.get("saved") else
                                            "in force but NOT saved: %s" % result.get("save_error"),
                                            "a quick re-calibration" if result.get("kind") == codes.QUICK else
                                            "%s calibration" % result.get("kind", codes.FULL)))
    if verify:
        print("verification: %d samples of corrected |B| over %.1f s: peak-to-peak %.3f nT, std %.3f nT" % verify)
    if previous is None:
        print("replaced: no calibration")
    else:
        print("replaced:")
        for line in calibration_lines(previous, status):
            print("  " + line)
    return 0


def _follow(dev, cfg, auto, view, keys):
    """Progress until the session ends; the final `cal` event (done, failed or cancelled)."""
    from desktop.link import DeviceError, LinkError

    last = time.monotonic()
    # a board slower than real time (the emulated Pico on a busy machine) is given --timeout:
    # its progress events come as much further apart
    silence = max(SILENCE_S, 2.5 * dev.timeout)
    while True:
        ev = dev.next_event(0.1)
        if ev is not None and ev.get("ev") == codes.EV_CAL:
            last = time.monotonic()
            if ev.get("state") != codes.COLLECTING:
                return ev
            view.update(ev, dev.ask("get-coverage") if view.wants_map else None)
            if auto and ev.get("ready") and not cfg.get("auto_finish", True):
                keys.pending = "finish"
        elif time.monotonic() - last > silence:
            raise LinkError("no calibration progress from %s for %.0f s: it stopped, reset or was unplugged"
                            % (dev.port, silence))
        key = keys.read()
        try:
            if key == "finish":
                return dev.ask("finish-cal", timeout=max(dev.timeout, 10.0))["result"]
            if key == "cancel":
                dev.ask("cancel-cal")   # the `cal` event with state "cancelled" follows
        except DeviceError as exc:
            if exc.code != codes.NOT_CALIBRATING:   # it finished by itself meanwhile: its event is coming
                raise


def _verify(dev, seconds, cfg):
    """(n, seconds, peak-to-peak, std) of corrected |B| streamed for `seconds`."""
    import statistics

    before = dev.ask("status")["stream"]
    dev.ask("stream corrected")
    try:
        f = [ev["f"] for ev in stream_events(dev, codes.EV_DATA, seconds, max(3.0, 5.0 / cfg["survey_hz"]))]
    finally:
        quietly(dev, "stream %s" % before)
    if len(f) < 2:
        return None
    return len(f), seconds, max(f) - min(f), statistics.pstdev(f)
