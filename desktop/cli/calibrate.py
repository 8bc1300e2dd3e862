"""fluxcal calibrate [--quick|--full] [--auto] [--replace]: run a calibration on the handheld, watched and steered from the laptop.

Starts a session (`start-cal`), shows the firmware's progress (`cal` events,
once a second), the coverage of the sphere (`get-coverage`) on an equal-area
map with the largest gap named and a warning when the sensor is not turning
(desktop/views/), and ends it: f or Enter finishes (`finish-cal`), c, q or Esc
cancels (`cancel-cal`, also on Ctrl-C, SIGTERM or a closed terminal). Without --auto the session is started
with `hold`, so the firmware waits for the operator's key even once it is ready
(at max_cal_s it ends any session); --auto waits for the firmware to finish by
itself, sending finish-cal itself at `ready` when the device's auto_finish is
off. Prints the result, its figures and the calibration it replaced. A full
calibration predicted no better than the one in force is not put in force by the
firmware (reason `worse_than_current`, the button's path alike): the operator
confirms it (a terminal), or --replace keeps it (`keep-cal`); otherwise the one in
force stays and the command exits 1 saying so in one line. A failed or cancelled
calibration leaves the previous one in force and exits 1.
"""

import signal
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
    p.add_argument("--replace", action="store_true",
                   help="keep the new calibration even when its predicted error is worse than the one it replaces")
    p.add_argument("--verify", type=float, default=0.0, metavar="S",
                   help="afterwards, S seconds of corrected |B| while you keep turning: its peak-to-peak and std")
    add_port_arguments(p)


KIND_WORDS = {
    codes.QUICK: "a quick re-calibration (the shape of the previous one kept, offsets and gains fitted anew)",
    codes.RESHAPED: "a reshaped calibration (a quick re-calibration whose samples showed the sensor's shape had"
                    " changed, so all nine parameters were fitted anew)",
}


def run(args):
    from desktop.cli._calibrate_view import Keys, Lines, Board
    from desktop.cli._show import calibration_lines, fit_figures

    with connected(args) as dev:
        cfg = device_config(dev)
        previous = dev.ask("get-cal")["cal"]
        status = dev.ask("status")
        _start(dev, "quick" if args.quick else "full" if args.full else "", hold=not args.auto)
        # a terminal closed or a `timeout` (SIGHUP, SIGTERM) cancels the session as Ctrl-C does: left
        # running, it kept the board busy and at max_cal_s put its own result in force
        for sig in (signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, _terminated)
        try:
            view = Board(cfg, args.auto) if sys.stdout.isatty() else Lines(cfg, args.auto)
            with view, Keys(enabled=not args.auto) as keys:
                result = _follow(dev, cfg, args.auto, view, keys)
        except BaseException:
            quietly(dev, "cancel-cal")     # leave no session running; a dead line is no news
            raise
        cov = dev.ask("get-coverage")
        if not sys.stdout.isatty():
            _print_map(cov, cfg, view)
        if result.get("state") == codes.CANCELLED:
            raise CommandError("calibration cancelled; the previous calibration stays in force")
        if result.get("reason") == codes.WORSE_THAN_CURRENT:
            result = _keep_or_not(dev, result, args)
        if result.get("state") != codes.DONE:
            raise CommandError("calibration failed (%s): %s; the previous calibration stays in force"
                               % (result.get("reason"), result.get("msg")))
        print("calibration done: %s; %s; %s" % (fit_figures(result),
                                                "saved, in force" if result.get("saved") else
                                                "in force but NOT saved: %s" % result.get("save_error"),
                                                KIND_WORDS.get(result.get("kind"),
                                                               "%s calibration" % result.get("kind", codes.FULL))))
        verify = _verify(dev, args.verify, cfg) if args.verify > 0 else None
    if verify:
        print("verification: %d samples of corrected |B| over %.1f s: peak-to-peak %.3f nT, std %.3f nT" % verify)
    if previous is None:
        print("replaced: none (no calibration was in force)")
    else:
        print("replaced:")
        for line in calibration_lines(previous, status):
            print("  " + line)
    return 0


def _terminated(signum, _frame):
    raise SystemExit(128 + signum)


def _start(dev, kind, hold):
    """start-cal KIND [hold]; a firmware that does not know `hold` gets a plain start-cal, said once."""
    from desktop.link import DeviceError

    plain = " ".join(w for w in ("start-cal", kind) if w)
    try:
        dev.ask(plain + " hold" if hold else plain)
    except DeviceError as exc:
        if not hold or exc.code != codes.BAD_ARGUMENT:
            raise
        print("note: this firmware finishes by itself when ready (it does not know `hold`): deploy the"
              " current one for a session that waits for your key", flush=True)
        dev.ask(plain)


def _print_map(cov, cfg, view):
    from desktop.views.coverage_text import guidance, map_lines

    counts, edge = cov["counts"], cov["cells_per_edge"]
    print("\n".join(map_lines(counts, edge, cfg["cell_cap"])))
    print(guidance(counts, edge))


def _keep_or_not(dev, result, args):
    """A calibration the firmware held back as no better than the one in force: put in force
    (keep-cal) with --replace or the operator's yes, the result then as a done one; else CommandError."""
    said = ("the new calibration's predicted full-sphere error %.3f nT is not below the %.3f nT of the one "
            "in force" % (result["predicted_error"], result["current_error"]))
    if args.replace:
        print("warning: %s; kept (--replace)" % said)
    elif not args.auto and sys.stdin is not None and sys.stdin.isatty() and sys.stdout.isatty():
        answer = input("%s%s. Keep the new one? [y/N] " % (said[0].upper(), said[1:]))
        if answer.strip().lower() not in ("y", "yes"):
            raise CommandError("%s: that one stays in force" % said)
    else:
        raise CommandError("%s (worse_than_current): that one stays in force; fluxcal calibrate --replace "
                           "keeps a worse one" % said)
    kept = dev.ask("keep-cal", timeout=max(dev.timeout, 10.0))
    return dict(result, state=codes.DONE, reason=None, saved=kept.get("saved"), in_force=True)


def _follow(dev, cfg, auto, view, keys):
    """Progress until the session ends; the final `cal` event (done, failed or cancelled)."""
    from desktop.link import DeviceError, LinkError

    last = time.monotonic()
    # a board slower than real time (the emulated Pico on a busy machine) is given --timeout:
    # its progress events come as much further apart
    silence = max(SILENCE_S, 2.5 * dev.timeout)
    while True:
        # the keys first: a finish or cancel acts before the view's round trips (get-coverage)
        key = keys.read()
        try:
            if key == "finish":
                return dev.ask("finish-cal", timeout=max(dev.timeout, 10.0))["result"]
            if key == "cancel":
                dev.ask("cancel-cal")   # the `cal` event with state "cancelled" follows
        except DeviceError as exc:
            if exc.code != codes.NOT_CALIBRATING:   # it finished by itself meanwhile: its event is coming
                raise
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
