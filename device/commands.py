"""The serial commands: one handler each, and their table (docs/protocol.md).

    Protocol(board, TABLE, app)      # protocol.py frames the lines, calls TABLE[cmd](app, args)

A handler gets the App and the text after the command word, and returns the
reply's fields as a dict; it acts through the App's owners (app.flow, app.output,
app.supervisor, app.guard, app.acq), each of which gives its own part of `status`. A request it refuses raises ProtocolError with a
stable code; a bad value from Calibration.from_dict or config.check is a
ValueError (bad_argument / bad_value).
"""

import gc
import json
import sys

import config as cfgmod
from protocol import VERSION, ProtocolError, json_number
from shared import codes
from shared.calibration import Calibration


def parse_value(text):
    """A config value from the wire: JSON scalar, else a bare word as a string."""
    t = text.strip()
    if t in ("true", "false", "null") or t[:1] in "-0123456789[{\"":
        try:
            return json.loads(t)
        except ValueError:
            raise ProtocolError(codes.BAD_VALUE, "cannot parse value %r" % t[:40])
    return t


def _idle(app):
    if app.flow.session is not None:
        raise ProtocolError(codes.BUSY, "calibration in progress; cancel-cal first")
    if app.recorder is not None:
        raise ProtocolError(codes.BUSY, "survey recording; survey stop first")


def version(app, args):
    return {"fw": app.firmware, "proto": VERSION, "runtime": app.board.name, "impl": sys.implementation.name}


def status(app, args):
    flow = app.flow
    out = {"state": "fault" if app.supervisor.fault else ("calibrating" if flow.session else "survey"),
           "config_problems": app.config_problems, "watchdog_ms": app.watchdog_ms,
           # the button's closings: timed by the pin's interrupt (hal button_edge) or found by the pass
           "button": "interrupt" if app.board.button_edges else "polled"}
    for part in (app.supervisor, app.guard, flow, app.output):
        out.update(part.status())
    if hasattr(gc, "mem_free"):   # MicroPython, CircuitPython
        out["mem_free"] = gc.mem_free()
    return out


def get_cal(app, args):
    cal = app.flow.cal
    return {"cal": cal.to_dict() if cal is not None else None}


def set_cal(app, args):
    _idle(app)
    if not args.startswith("{"):
        raise ProtocolError(codes.BAD_ARGUMENT, "set-cal takes a calibration JSON object")
    try:
        d = json.loads(args)
    except ValueError:
        raise ProtocolError(codes.BAD_JSON, "set-cal argument is not valid JSON")
    cal = Calibration.from_dict(d)  # ValueError names the problem
    from acceptance import check_calibration   # here: the session's, not held while idle (calibration_flow.py)
    problem = check_calibration(cal, app.cfg, app.flow.scale)
    if problem:
        raise ProtocolError(problem[0], problem[1])
    cal.meta["source"] = "set-cal"
    saved, err = app.flow.install(cal, "set-cal")
    if not saved:
        raise ProtocolError(codes.IO_ERROR, "calibration active but not saved: %s" % err)
    return {"saved": True}


def keep_cal(app, args):
    # the full calibration the last session refused as worse than the one in force, put in force
    _idle(app)
    saved, err = app.flow.keep()
    if not saved:
        raise ProtocolError(codes.IO_ERROR, "calibration active but not saved: %s" % err)
    return {"saved": True}


def clear_cal(app, args):
    _idle(app)
    try:
        app.flow.clear()
    except OSError as e:
        raise ProtocolError(codes.IO_ERROR, "cal.json could not be removed (%s): the calibration stays in force"
                            % (e,))
    return {}


def start_cal(app, args):
    if app.recorder is not None:
        raise ProtocolError(codes.BUSY, "survey recording; survey stop first")
    # start-cal [auto|full|quick] [hold]: auto (the button's short press) ends quick when a
    # calibration is in force and the coverage stays partial, else full; hold: the session
    # waits for finish-cal (or the button) even once it is ready and auto_finish is on
    words = args.split()
    hold = "hold" in words
    if hold:
        words.remove("hold")
    if len(words) > 1:
        raise ProtocolError(codes.BAD_ARGUMENT, "start-cal takes [auto|full|quick] [hold]")
    app.flow.start(words[0] if words else codes.AUTO, hold)
    return {"kind": app.flow.session.kind}


def finish_cal(app, args):
    return {"result": app.flow.finish()}


def cancel_cal(app, args):
    app.flow.cancel()
    return {}


def get_coverage(app, args):
    flow = app.flow
    cov = flow.session.cov if flow.session is not None else flow.last_coverage
    if cov is None:
        raise ProtocolError(codes.NO_COVERAGE, "no calibration since boot")
    return {"cells_per_edge": cov.edge, "counts": list(cov.counts), "fraction": json_number(cov.fraction())}


def stream(app, args):
    words = args.split()
    if words[:1] == ["on"]:
        words = words[1:] or ["corrected"]
    if len(words) != 1 or words[0] not in ("off", "raw", "corrected"):
        raise ProtocolError(codes.BAD_ARGUMENT, "stream takes: on [raw|corrected] | raw | corrected | off")
    app.output.set_stream(words[0])
    return {"stream": app.output.stream}


def config(app, args):
    words = args.split(None, 2)
    if not words or words[0] not in ("get", "set"):
        raise ProtocolError(codes.BAD_ARGUMENT, "config get [KEY] | config set KEY VALUE")
    if words[0] == "get":
        if len(words) == 1:
            return {"config": app.cfg}
        return {"key": words[1], "value": app.cfg[_known_key(app, words[1])]}
    if len(words) != 3:
        raise ProtocolError(codes.BAD_ARGUMENT, "config set KEY VALUE")
    _idle(app)
    key = _known_key(app, words[1])
    new = dict(app.cfg)
    try:
        new[key] = cfgmod.check(key, parse_value(words[2]))
        cfgmod.cross_check(new)
    except ValueError as e:
        raise ProtocolError(codes.BAD_VALUE, str(e))
    app.apply_config(new)
    return {"key": key, "value": new[key]}


def _known_key(app, key):
    if key not in app.cfg:
        raise ProtocolError(codes.UNKNOWN_KEY, "unknown config key %r" % key[:40])
    return key


def repl(app, args):
    """Hand the serial line back to the REPL: this reply goes out, then App.run returns and
    main.py / code.py ends, so mpremote can take the line (fluxcal deploy) without the button."""
    _idle(app)
    app.quit = True
    return {}


def survey(app, args):
    """survey start [MAX_BYTES] | stop | info | read OFFSET: surveylog.py, imported on the first use
    (a handheld that never surveys never loads it)."""
    import surveylog
    return surveylog.command(app, args)


def help_(app, args):
    names = list(TABLE)
    names.sort()
    return {"commands": names}


TABLE = {
    "version": version,
    "status": status,
    "get-cal": get_cal,
    "set-cal": set_cal,
    "keep-cal": keep_cal,
    "clear-cal": clear_cal,
    "start-cal": start_cal,
    "finish-cal": finish_cal,
    "cancel-cal": cancel_cal,
    "get-coverage": get_coverage,
    "stream": stream,
    "config": config,
    "repl": repl,
    "survey": survey,
    "help": help_,
}
