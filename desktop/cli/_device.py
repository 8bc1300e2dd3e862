"""What the commands that talk to a handheld share: --port, --timeout, and one connection.

    def add_arguments(p):
        add_port_arguments(p)
    def run(args):
        with connected(args) as dev:      # LinkError -> CommandError (one line, exit 1)
            dev.ask("status")

Not a command (COMMANDS does not list it).
"""

import contextlib
import sys

from desktop.cli._errors import CommandError
from shared import codes


def add_port_arguments(p):
    p.add_argument("--port", help="serial port of the handheld (default: the one MicroPython or "
                                  "CircuitPython board attached, found by its USB id)")
    p.add_argument("--timeout", type=float, default=2.0, metavar="S",
                   help="seconds to wait for each reply from the device (default 2)")


@contextlib.contextmanager
def connected(args):
    """An open, version-checked Device; device and link failures become CommandError."""
    from desktop.link import LinkError, open_device

    if not args.timeout > 0:
        raise CommandError("--timeout must be a positive number of seconds")
    try:
        dev = open_device(args.port, timeout=args.timeout)
    except LinkError as exc:
        raise CommandError(str(exc)) from None
    try:
        yield dev
    except LinkError as exc:
        raise CommandError(str(exc)) from None
    else:
        if dev.reader.skipped:   # tolerated, but a person should know the line is noisy
            print("fluxcal: note: skipped %d pieces of line noise from %s" % (dev.reader.skipped, dev.port),
                  file=sys.stderr)
    finally:
        dev.close()


def quietly(dev, command):
    """Send a clean-up request (stream off, cancel-cal) on the way out; a dead line is no news then."""
    from desktop.link import LinkError

    try:
        dev.ask(command)
    except LinkError:
        pass


def device_config(dev):
    """The device's whole configuration (`config get`)."""
    return dev.ask("config get")["config"]


def nT_per_code(config):
    """The device's front-end scale, nT per ADC code, per axis."""
    return [float(config["scale_" + a]) for a in "xyz"]


def stream_events(dev, name, seconds=None, silence=None):
    """Yield the device's `name` events ("data", "raw") for `seconds` (None: until interrupted).

    A stream that stops for `silence` seconds (default 3; at least 1.5 --timeout, so a board
    given a longer one, slower than real time like the emulated Pico, is waited for as much
    longer) is a device that died or was unplugged: LinkError, one line.
    """
    import time

    from desktop.link import LinkError

    silence = max(3.0 if silence is None else silence, 1.5 * dev.timeout)

    end = None if seconds is None else time.monotonic() + seconds
    last = time.monotonic()
    while end is None or time.monotonic() < end:
        wait = silence if end is None else max(0.0, min(silence, end - time.monotonic()))
        ev = dev.next_event(wait)
        now = time.monotonic()
        if ev is not None and ev.get("ev") == name:
            last = now
            yield ev
        elif ev is not None and ev.get("ev") == codes.EV_BOOT:
            raise LinkError("the device on %s rebooted (a reset or the power)" % dev.port)
        elif now - last >= silence:
            raise LinkError("no %s from the device on %s for %.0f s: it stopped, reset or was unplugged"
                            % (name, dev.port, silence))



def save_device_calibration(record, scale, path):
    """A calibration record the handheld sent (get-cal), validated, written to `path` in its code
    units with the front end's scale (pull-cal's file); the Calibration. CommandError if invalid."""
    from desktop.formats.calibration import CODE_UNITS, plausibility_problem, save_calibration
    from shared.calibration import Calibration

    try:
        cal = Calibration.from_dict(record)
    except ValueError as exc:
        raise CommandError("the handheld sent an invalid calibration: %s" % exc)
    problem = plausibility_problem(cal)
    if problem:
        raise CommandError("the handheld's calibration is not plausible, not written: %s" % problem)
    cal.meta["units"] = CODE_UNITS
    cal.meta.setdefault("scale", scale)
    save_calibration(path, cal)
    return cal
