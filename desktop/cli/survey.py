"""fluxcal survey --grid WxL --line-spacing S [--zigzag] [--pace S_PER_M] [--metronome] [--gps PORT] -o SURVEY.npz

Records a walked survey from the handheld: its |B| blocks (the `corrected` stream,
10 a second by default) on the board's clock, and a mark at each short press of
the button (the handheld's `survey` mode: press at the start and at the end of
every line, as with a Grad601). The handheld logs the same to its flash
(device/surveylog.py), so a lost connection loses no line: `--resume` reconnects
and continues the file, `--pull` (after the walk) stops the handheld's recording
and completes the file from its log. The file is what `fluxcal map` reads
(desktop/survey/recording.py); it is rewritten at every mark and every
SAVE_EVERY_S, so a laptop that dies keeps all but the last seconds, which the
flash log has.

It ends once every line of the grid is marked (2 presses a line), or at Ctrl-C
(the lines marked so far are kept). --metronome: a beep per metre at the pace
from each line's start, two at its end (the terminal's bell and a count).
"""

import os
import sys
import time

from desktop.cli._device import add_port_arguments, connected, device_config, nT_per_code, quietly
from desktop.cli._errors import CommandError
from desktop.formats import FormatError

HELP = "record a walked survey from the handheld: |B|, line marks from the button, a GPS; resume or pull its log"
SAVE_EVERY_S = 10.0
SILENCE_S = 3.0         # no data event for this long: the handheld is gone (unplugged, reset)


def add_arguments(p):
    p.add_argument("-o", "--output", required=True, metavar="SURVEY.npz", help="the survey file (fluxcal map reads it)")
    p.add_argument("--grid", metavar="WxL", help="grid width (east) x length (north), m, e.g. 20x20")
    p.add_argument("--line-spacing", type=float, metavar="S", help="metres between lines")
    p.add_argument("--zigzag", action="store_true", help="walk every other line back (default: every line north)")
    p.add_argument("--pace", type=float, default=1.0, metavar="S_PER_M", help="seconds per metre (default 1)")
    p.add_argument("--metronome", action="store_true", help="beep every metre at the pace, twice at a line's end")
    p.add_argument("--gps", metavar="PORT", help="a GPS receiver's serial port (NMEA; needs fluxcal[gps])")
    p.add_argument("--gps-baud", type=int, default=9600, metavar="BAUD", help="the GPS port's speed (default 9600)")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--resume", action="store_true", help="reconnect to a handheld still recording and continue")
    what.add_argument("--pull", action="store_true", help="stop the handheld's recording and complete the file "
                                                          "from its flash log")
    add_port_arguments(p)


def grid_from_args(args):
    """The grid's settings, or None when --grid is not given; CommandError for a bad one."""
    if args.grid is None:
        if args.line_spacing is not None:
            raise CommandError("--line-spacing goes with --grid WxL")
        return None
    from desktop.cli._survey_grid import parse_grid
    width, length = parse_grid(args.grid, args.line_spacing)
    if not 0.2 <= args.pace <= 10:
        raise CommandError("--pace must be within 0.2..10 s per metre")
    return dict(width_m=width, length_m=length, spacing_m=args.line_spacing, zigzag=args.zigzag,
                pace_s_per_m=args.pace)


def _ticks_period(info):
    """The board's ticks_ms wraps here: 2**29 ms on CircuitPython (supervisor.ticks_ms), else 2**30."""
    return 1 << 29 if info.get("impl") == "circuitpython" else 1 << 30


def pull_log(dev, offset=0):
    """The handheld's survey log from `offset` (bytes), by `survey read` chunks."""
    out = bytearray()
    while True:
        r = dev.ask("survey read %d" % (offset + len(out)))
        data = bytes.fromhex(r["data"])
        out += data
        if not data or offset + len(out) >= r["size"]:
            return bytes(out)


def _survey_info(dev):
    from desktop.link import DeviceError
    from shared import codes
    try:
        return dev.ask("survey info")
    except DeviceError as exc:
        if exc.code == codes.UNKNOWN_COMMAND:
            raise CommandError("the handheld's firmware records no surveys: fluxcal deploy updates it") from None
        raise


def _check_output(args, grid):
    """Before the handheld is asked anything: a survey file is never overwritten unless continued,
    and a new one needs its grid and a folder to go in."""
    exists = os.path.exists(args.output)
    if exists and not (args.resume or args.pull):
        raise CommandError("%s exists: --resume continues it, --pull completes it from the handheld; "
                           "or give another name" % args.output)
    if not exists and grid is None:
        raise CommandError("--grid WxL and --line-spacing S are needed%s" % (
            "" if not (args.resume or args.pull) else " (%s does not exist yet)" % args.output))
    if not os.path.isdir(os.path.dirname(os.path.abspath(args.output))):
        raise CommandError("%s: directory does not exist" % os.path.dirname(os.path.abspath(args.output)))


def _open_recording(args, grid, dev):
    """The file to continue (--resume, --pull), or a new Recording of this handheld."""
    from desktop.survey.recording import Recording
    if os.path.exists(args.output):
        return Recording.load(args.output)
    meta = {"port": dev.port, "version": dev.info, "device_config": device_config(dev)}
    return Recording(grid, nT_per_code(meta["device_config"]), meta)


def run(args):
    grid = grid_from_args(args)
    _check_output(args, grid)
    if args.gps and args.pull:
        raise CommandError("--gps records while walking; --pull reads the handheld's log only")
    gps = None
    if args.gps:
        from desktop.link import LinkError
        from desktop.link.gps import GpsReader
        try:
            gps = GpsReader(args.gps, args.gps_baud)
        except LinkError as exc:
            raise CommandError(str(exc)) from None
    try:
        with connected(args) as dev:
            info = _survey_info(dev)
            rec = _open_recording(args, grid, dev)
            if args.pull:
                return _pull(dev, info, rec, args.output)
            if gps is not None:
                gps.start()
            return _record(dev, info, rec, args, gps)
    finally:
        if gps is not None:
            gps.stop()


def _pull(dev, info, rec, path):
    if info.get("recording"):
        dev.ask("survey stop")
    raw = pull_log(dev)
    if len(raw) <= 8:
        raise CommandError("the handheld holds no survey log (none recorded since its flash was cleared)")
    got, marks = rec.merge_log(raw)
    rec.save(path)
    print("pulled %d bytes of the handheld's survey log: %d readings and %d marks not in the file before" %
          (len(raw), got, marks))
    return _summary(rec, path)


def _summary(rec, path):
    from desktop.survey.recording import line_count
    print("wrote %s: %d readings (%d streamed, %d from the flash log), %d of %d lines marked%s" % (
        path, len(rec.readings), rec.sources["stream"], rec.sources["flash log"], rec.lines_done(),
        line_count(rec.grid), "" if len(rec.marks) % 2 == 0 else ", a line begun but not ended"))
    return 0


def _record(dev, info, rec, args, gps):
    from desktop.link import LinkError
    from desktop.survey.recording import line_count
    from shared import codes

    if args.resume:
        if not info.get("recording"):
            raise CommandError("the handheld is not recording a survey (stopped or restarted): "
                               "fluxcal survey --pull -o %s completes the file from its flash log" % args.output)
    elif info.get("recording"):
        raise CommandError("the handheld is recording a survey already (%d marks): --resume -o FILE continues it, "
                           "--pull -o FILE ends it and saves its log" % info.get("marks", 0))
    stream_before = dev.ask("status")["stream"]
    if not args.resume:
        info = dev.ask("survey start")
    dev.ask("stream corrected")
    t0, period = info["t0"], _ticks_period(dev.info)
    if args.resume:
        got, marks = rec.merge_log(pull_log(dev))
        print("resumed: %d readings and %d marks from the handheld's flash log" % (got, marks), flush=True)
    n_lines = line_count(rec.grid)
    print("recording %s: %d lines; press the button at the start and at the end of each line (Ctrl-C stops)" %
          (args.output, n_lines), flush=True)
    beat = _Metronome(rec.grid) if args.metronome else None
    arrivals = []           # (laptop s, board s) of data events: the GPS fixes' clock
    saved_at = time.monotonic()
    ended = "complete"
    try:
        last = time.monotonic()
        while not rec.complete():
            ev = dev.next_event(0.05 if beat else 0.5)
            now = time.monotonic()
            if beat:
                beat.tick(now)
            if ev is None:
                if now - last > max(SILENCE_S, 1.5 * dev.timeout):
                    raise LinkError("no data from the handheld on %s for %.0f s" % (dev.port, now - last))
                continue
            name = ev.get("ev")
            if name == "data":
                last = now
                ms = (ev["t"] - t0) % period
                # a block from before `survey start` (ms 0 too: taken in the pass that ran it, before
                # it) is not the survey's; the log has every block that is
                if 0 < ms < period // 2:
                    rec.reading(ms, ev["f"], ev.get("c"), ev.get("temp"))
                    rec.meta["handheld_calibrated"] = bool(ev.get("cal"))
                    arrivals.append((now, ms / 1000.0))
            elif name == "mark":
                if rec.mark(ev["ms"]):
                    k = len(rec.marks)
                    print("line %d %s (mark %d)" % ((k + 1) // 2, "started" if k % 2 else "ended", k), flush=True)
                    if beat:
                        beat.mark(now, k)
                    saved_at = _save(rec, args.output, gps, arrivals)
            elif name == "survey" and ev.get("state") == "log_full":
                print("note: the handheld's flash log is full (%d bytes): the rest is in the stream only"
                      % ev.get("bytes", 0), file=sys.stderr, flush=True)
            elif name == codes.EV_BOOT:
                raise LinkError("the handheld rebooted (a reset or the power)")
            if now - saved_at >= SAVE_EVERY_S:
                saved_at = _save(rec, args.output, gps, arrivals)
    except LinkError as exc:
        _save(rec, args.output, gps, arrivals)
        raise CommandError("%s: %d of %d lines marked, saved to %s; the handheld records on to its flash: "
                           "reconnect and run fluxcal survey --resume -o %s" % (
                               str(exc).rstrip("."), rec.lines_done(), n_lines, args.output, args.output))
    except KeyboardInterrupt:
        ended = "stopped at Ctrl-C"
    try:        # the handheld stops recording; then the blocks the stream did not bring, from its log
        dev.ask("survey stop")
        rec.merge_log(pull_log(dev))
    except LinkError as exc:
        print("note: %s (the handheld may still be recording: --pull completes the file)" % exc, file=sys.stderr)
    quietly(dev, "stream %s" % stream_before)
    _save(rec, args.output, gps, arrivals)
    print("survey %s" % ended)
    return _summary(rec, args.output)


def _save(rec, path, gps, arrivals):
    if gps is not None and arrivals:
        import numpy as np
        # the board's clock against the laptop's, by the data's arrivals: a line (two crystals
        # differ by tens of ppm, seconds a day; an emulator may run slower than real time)
        lap, board = np.asarray(arrivals, dtype=float).T
        rate, offset = np.polyfit(lap, board, 1) if np.ptp(lap) > 1.0 else (1.0, float(np.median(board - lap)))
        rec.gps = [(rate * t + offset, lat, lon, q) for t, lat, lon, q in gps.fixes()]
        rec.meta["gps"] = {"port": gps.port, "fixes": len(rec.gps), "bad_sentences": gps.bad}
    try:
        rec.save(path)
    except FormatError as exc:
        raise CommandError(str(exc))
    return time.monotonic()


class _Metronome:
    """A beep every metre at the pace from a line's start mark, two at its end (the grid's length)."""

    def __init__(self, grid):
        self.pace = grid["pace_s_per_m"]
        self.length = grid["length_m"]
        self.start = None
        self.metres = 0
        self.tty = sys.stdout.isatty()

    def mark(self, now, k):
        self.start = now if k % 2 else None     # odd marks start a line
        self.metres = 0

    def tick(self, now):
        if self.start is None or self.metres >= self.length:
            return
        if now - self.start >= (self.metres + 1) * self.pace:
            self.metres += 1
            end = self.metres >= self.length
            bell = ("\a\a" if end else "\a") if self.tty else ""
            print("%sbeep %d m%s" % (bell, self.metres, ": line end" if end else ""), flush=True)
