"""fluxcal emulate [--runtime R] [--sensor S] [--flash DIR] [--bare] [--operator MODE] [--script FILE] [--seconds S]
                 [--survey WxL --line-spacing S [--zigzag] [--site SEED]]

--operator: what the virtual operator does from the start: follow (the LED: turn
while it says "collecting", hold still otherwise), turn (turn the sensor by hand
all the time, as an operator does during `fluxcal capture`), hold (keep it
still). Keys and --script change it later.

--survey: the operator is a surveyor on a simulated site (buried iron, a pipe, soil
clutter, diurnal drift: desktop/sim/site.py) who waits at the first line's start and, on
`walk` (key w, or a script's line), walks the grid and presses the button at the start
and the end of every line (desktop/devicesim/walker.py): `fluxcal survey` records it.
"""

import os

HELP = "a virtual handheld on a pseudo-terminal: the firmware on the simulated fluxgate, in real time"

OPERATOR = {"follow": "follow", "turn": "hand", "hold": "hold"}     # --operator -> the operator's action
KEYS = {"r": "hand", "h": "hold", "s": "spin", "f": "follow", "p": "press", "l": "long-press", "c": "power-cycle",
        "w": "walk"}
STATUS_S = 10.0
BOOT_WAIT_S = 300.0   # the emulated Pico's boot takes wall seconds, many on a loaded machine


def add_arguments(p):
    from desktop.devicesim.virtual_handheld import RUNTIMES
    p.add_argument("--runtime", choices=RUNTIMES + ("pico", "cpython"), default="micropython",
                   help="the interpreter the board runs (default micropython; pico: the rp2 port's own"
                        " firmware on an emulated Raspberry Pi Pico; cpython: the firmware in this process,"
                        " no REPL)")
    p.add_argument("--frozen", action="store_true",
                   help="--runtime pico: the image with the firmware frozen in (make pico-frozen: its bytecode in"
                        " flash, the solver's kernels taken; a deploy adds only what it lacks)")
    p.add_argument("--sensor", choices=("mag649", "mag648"), default="mag649")
    p.add_argument("--seed", type=int, default=0, help="the sensor's errors")
    p.add_argument("--flash", help="the board's flash folder (default: a new temporary one)")
    p.add_argument("--bare", action="store_true", help="a board with an empty flash: only the REPL")
    p.add_argument("--operator", choices=tuple(OPERATOR), default="follow",
                   help="follow the LED (default: turn while it says collecting), turn all the time (a capture"
                        " records a turning sensor), or hold still")
    p.add_argument("--script", help="the operator's actions: lines 'SECONDS ACTION [ARG]', e.g. '2 press'")
    p.add_argument("--seconds", type=float, help="stop after this long (default: until Ctrl-C or 'q')")
    p.add_argument("--survey", metavar="WxL", help="a surveyor on a simulated site of this grid, m (walks on 'walk')")
    p.add_argument("--line-spacing", type=float, default=1.0, metavar="S", help="--survey's lines, m apart (default 1)")
    p.add_argument("--zigzag", action="store_true", help="--survey: walk every other line back")
    p.add_argument("--site", type=int, default=0, metavar="SEED", help="--survey: the site's objects and clutter")
    p.add_argument("--speed", type=float, default=1.0,
                   help="simulated seconds per wall second (default 1: real time; more, to test a machine's margin)")


def read_script(path):
    """[(seconds, action, arg or None)] from a script file; CommandError naming the bad line."""
    from desktop.cli._errors import CommandError
    from desktop.devicesim.virtual_handheld import ACTIONS
    out = []
    try:
        lines = open(path).read().splitlines()
    except OSError as exc:
        raise CommandError("cannot read the script %s: %s" % (path, exc.strerror))
    for k, line in enumerate(lines, 1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        try:
            t = float(words[0])
        except ValueError:
            t = None
        if t is None or len(words) not in (2, 3) or words[1] not in ACTIONS or t < 0:
            raise CommandError("%s line %d: want 'SECONDS ACTION [ARG]' with ACTION one of %s"
                               % (path, k, ", ".join(ACTIONS)))
        out.append((t, words[1], words[2] if len(words) == 3 else None))
    return sorted(out, key=lambda a: a[0])


def run(args):
    import os
    import sys
    import tempfile
    import threading
    import time

    from desktop.cli._errors import CommandError
    from desktop.devicesim.virtual_handheld import InProcessHandheld, VirtualHandheld
    from desktop.link.ports import announce_emulator

    if args.frozen and args.runtime != "pico":
        raise CommandError("--frozen is the Pico's image with the firmware frozen in: --runtime pico --frozen")
    script = read_script(args.script) if args.script else []
    survey = _survey(args)
    behind = []

    def on_behind(lag, capacity):
        behind.append((lag, capacity))
        done.set()

    done = threading.Event()
    tmp = tempfile.TemporaryDirectory(prefix="fluxcal-emulate-") if args.flash is None else None
    flash = os.path.abspath(args.flash or os.path.join(tmp.name, "flash"))
    os.makedirs(flash, exist_ok=True)
    if args.runtime == "cpython":
        hh = InProcessHandheld(os.path.dirname(flash), sensor=args.sensor, seed=args.seed, speed=args.speed,
                               on_behind=on_behind, survey=survey)
    elif args.runtime == "pico":
        from desktop.devicesim.pico_handheld import PicoHandheld
        try:        # its clock is the emulated chip's: no --speed, it never runs ahead of real time
            hh = PicoHandheld(flash, sensor=args.sensor, seed=args.seed, frozen=args.frozen)
        except FileNotFoundError as exc:
            raise CommandError(str(exc))
    else:
        try:
            hh = VirtualHandheld(flash, runtime=args.runtime, sensor=args.sensor, seed=args.seed, speed=args.speed,
                                 on_behind=on_behind, survey=survey)
        except FileNotFoundError as exc:
            raise CommandError(str(exc))
    keys = _Keys(hh, done)
    # A terminated emulator takes its board down with it: SIGTERM / SIGHUP unwind through the
    # finally below (by default they end Python at once, and the board's interpreter, a child
    # process reading a pty nobody writes to any more, kept spinning).
    import signal

    def _terminated(signum, _frame):
        raise SystemExit(128 + signum)
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _terminated)
    announced = None
    try:
        hh.start()
        if args.operator != "follow" and survey is None:
            hh.act(OPERATOR[args.operator])
        print("fluxcal emulate: virtual handheld (%s, %s) on %s" % (args.runtime, args.sensor, hh.port), flush=True)
        announced = announce_emulator(hh.port, args.runtime)    # `fluxcal status` without --port finds it
        if args.runtime != "cpython" and not args.bare:
            # the port is printed, but until the firmware answers it is the emulator's: a client
            # opening it meanwhile is told the board is busy, and cannot break the deploy
            own = hh.hold_port("starting its firmware")
            try:
                _deploy_if_empty(hh, flash, own, wait_s=BOOT_WAIT_S if args.runtime == "pico" else 20.0)
                if args.runtime == "pico":    # its boot takes wall seconds: ready when the firmware answers
                    hh.hold_port("starting its firmware")
                    _await_firmware(hh, own)
            finally:
                hh.release_port()
        print("ready: %s" % ("an empty board, its REPL on the port" if args.bare else "the firmware runs"),
              flush=True)
        if keys.from_terminal():
            first = "w walk the survey" if survey else "r turn by hand, h hold, s spin, f follow the LED"
            print("keys: %s, p press, l long press, c power cycle, q quit" % first, flush=True)
        keys.start()
        t0 = time.monotonic()
        nxt = STATUS_S
        while not done.is_set():
            now = time.monotonic() - t0
            while script and script[0][0] <= now:
                _t, action, arg = script.pop(0)
                _act(hh, action, arg)
            if args.seconds is not None and now >= args.seconds:
                break
            if now >= nxt:
                nxt += STATUS_S
                _status(hh, now)
            done.wait(0.05)
    finally:
        if announced is not None:
            os.remove(announced)
        keys.stop()
        hh.close()
        if tmp is not None:
            tmp.cleanup()
    if behind:
        lag, capacity = behind[0]
        raise CommandError("the firmware fell %.1f s behind %s (it runs at %s real time on this machine)"
                           % (lag, "real time" if args.speed == 1 else "%gx real time" % args.speed,
                              "%.2fx" % capacity if capacity else "less than %gx" % args.speed))
    return 0


def _survey(args):
    """--survey's settings for the Scenario (desktop/sim/scenario.py), None without it."""
    from desktop.cli._errors import CommandError
    if args.survey is None:
        return None
    if args.runtime == "pico":
        raise CommandError("--survey runs on the simulated boards (not --runtime pico)")
    from desktop.cli._survey_grid import parse_grid
    width, length = parse_grid(args.survey, args.line_spacing, "--survey")
    return dict(width_m=width, length_m=length, spacing_m=args.line_spacing, zigzag=args.zigzag,
                site_seed=args.site)


def _act(hh, action, arg):
    from desktop.cli._errors import CommandError
    try:
        hh.act(action, arg)
    except ValueError as exc:
        raise CommandError(str(exc))


def _status(hh, now):
    p = hh.pacer
    cap = "%.1fx" % p.capacity if p is not None and p.capacity else "-"
    if hasattr(hh.operator, "begin"):
        who = "a surveyor"
    else:   # in the words of --operator and the keys (the operator's own modes: hand, hold, spin)
        doing = {"hand": "turning", "hold": "holding still", "spin": "spinning"}.get(hh.operator.mode, hh.operator.mode)
        who = "following the LED, %s" % doing if hh.hands.following else doing
    print("%6.0f s  simulated %.1f s  capacity %s real time  operator: %s" % (now, hh.world.time, cap, who), flush=True)


def _deploy_if_empty(hh, flash, own, wait_s):
    """A flash without firmware gets it as a board does: by fluxcal deploy's own code, over the
    board's port with mpremote (MicroPython), or into its drive folder (CircuitPython), then a reset.
    own: the emulator's own line to the board (hold_port) while clients of hh.port wait."""
    import os

    from desktop.cli._errors import CommandError
    from desktop.cli.deploy import check_version
    from desktop.firmware.deploy import DeployError, MicroPythonDeploy, deploy_drive, firmware_version

    entry = "code.py" if hh.runtime == "circuitpython" else "main.py"
    if getattr(hh, "fresh", None) is False or os.path.exists(os.path.join(flash, entry)):
        return      # (the Pico's flash is one file, FLASH/pico.flash: fresh until it exists)
    print("the flash holds no firmware: deploying it (fluxcal deploy)", flush=True)
    hh.hold_port("deploying its firmware")
    try:
        if hh.runtime == "circuitpython":
            done = deploy_drive(flash)
            hh.act("power-cycle")
        else:
            done = MicroPythonDeploy(own, compiled=True).run()
    except DeployError as exc:
        raise CommandError(" ".join(str(exc).split()).replace(own, hh.port)) from None
    check_version(own, firmware_version(hh.runtime), wait_s=wait_s)
    print(done.replace(own, hh.port), flush=True)


def _await_firmware(hh, own):
    """The emulated Pico boots at its emulated speed (seconds of wall time while the firmware's
    modules load): "ready" once its firmware answers, so that a client does not find it mute."""
    from desktop.cli.deploy import check_version
    from desktop.firmware.deploy import firmware_version
    check_version(own, firmware_version(hh.runtime), wait_s=BOOT_WAIT_S)


class _Keys:
    """Single keys from standard input while emulate runs: from the terminal (cbreak mode, restored
    at exit) or from a pipe (a program steering the operator); nothing when it is closed."""

    def __init__(self, hh, done):
        self.hh = hh
        self.done = done
        self._old = None
        self._fd = None

    @staticmethod
    def _stdin():
        """Standard input's file descriptor, or None when there is none: started with it closed
        (Python then sets sys.stdin to None) or closed since."""
        import sys
        if sys.stdin is None or sys.stdin.closed:
            return None
        try:
            return sys.stdin.fileno()
        except (OSError, ValueError):
            return None

    def from_terminal(self):
        fd = self._stdin()
        return fd is not None and os.isatty(fd)

    def start(self):
        import threading
        fd = self._stdin()
        if fd is None:
            return
        if os.isatty(fd):
            import termios
            import tty
            self._old = termios.tcgetattr(fd)
            tty.setcbreak(fd)
        self._fd = fd
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        import select
        fd = self._fd
        while not self.done.is_set():
            try:
                if not select.select([fd], [], [], 0.1)[0]:
                    continue
                data = os.read(fd, 64).decode(errors="replace")
            except (OSError, ValueError):
                # the input went away under the reader (a terminal hung up, the descriptor closed):
                # as at its end, the operator carries on as it was
                return
            if not data:
                return          # end of input: the operator carries on as it was
            for key in data:
                if key == "q":
                    self.done.set()
                elif key in KEYS:
                    try:
                        self.hh.act(KEYS[key])
                    except ValueError as exc:
                        _say("(%s)" % exc)

    def stop(self):
        if self._old is not None:
            import termios
            try:
                termios.tcsetattr(self._fd, termios.TCSADRAIN, self._old)
            except (termios.error, OSError):
                pass        # the terminal is gone: there is no mode left to restore


def _say(line):
    """A line from the key reader's thread: a reader of standard output that went away is not
    the thread's to report (main's BrokenPipeError handler says nothing either)."""
    try:
        print(line, flush=True)
    except (BrokenPipeError, ValueError):
        pass
