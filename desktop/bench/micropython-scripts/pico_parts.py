# MicroPython script for the emulated Pico (desktop/bench/pico.py sends it to the REPL once the
# firmware has handed the line back): the firmware started as main.py starts it, with the entry
# points of its parts wrapped to name the part that runs on the runner's profiling port
# (desktop/devicesim/pico/parts.mjs, an address only the emulator has). Each wrapper writes its
# part's number there (with ENTRY: the runner counts a call), calls the function, and writes its
# caller's number back, so a nested part (add() inside the gates) is charged to itself and its
# caller gets the rest. The callers are fixed by the firmware's structure (PARENT), but for the
# finish (the button, a command or the flow's auto-finish) and the solve (provisional or final),
# which read the caller's number back first. Allocation-free where it runs per sample (fixed
# arities, no *args); no try/finally (it costs cycles at every call): an exception through a
# wrapper leaves its part named until the next wrapper returns. The wrappers' calls and writes
# are the profiling's cost, which the bench measures as the load with them against the load
# without. The DRDY handler needs none: it is a hard IRQ, counted by the runner as the exception.
import sys

import acquisition
import app
import button
import calibration_flow
import hal_micropython
import health
import led
import protocol
import screen
import survey
from machine import mem32
from micropython import const

_PORT = const(0x40068000)
_ENTRY = const(0x100)      # on the way in: the runner counts a call (reads give the number alone)
# the parts' numbers, as desktop/bench/pico.py names them (0: the rest of the main loop)
REST, SCREEN, GATES, ADD, SOLVE, OUTPUT, PROTOCOL, SLEEP, FINISH, HOUSE, TICK, BATCHES = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11


def _w1(f, part, parent):
    def w(a):
        mem32[_PORT] = part | _ENTRY
        r = f(a)
        mem32[_PORT] = parent
        return r
    return w


def _w2(f, part, parent):
    def w(a, b):
        mem32[_PORT] = part | _ENTRY
        r = f(a, b)
        mem32[_PORT] = parent
        return r
    return w


def _w3(f, part, parent):
    def w(a, b, c):
        mem32[_PORT] = part | _ENTRY
        r = f(a, b, c)
        mem32[_PORT] = parent
        return r
    return w


def _w4(f, part, parent):
    def w(a, b, c, d):
        mem32[_PORT] = part | _ENTRY
        r = f(a, b, c, d)
        mem32[_PORT] = parent
        return r
    return w


def _w5(f, part, parent):
    def w(a, b, c, d, e):
        mem32[_PORT] = part | _ENTRY
        r = f(a, b, c, d, e)
        mem32[_PORT] = parent
        return r
    return w


def _nested(f, part, _parent):
    def w(*a, **k):
        prev = mem32[_PORT]
        mem32[_PORT] = part | _ENTRY
        r = f(*a, **k)
        mem32[_PORT] = prev
        return r
    return w


def _screen(init):
    """Screen.__init__ that wraps the new screen's push in the instance, where a native push
    (screenc.mpy) lives: what it hands back to the class's push is charged to it too."""
    def w(self, scale, window, spike_nt, native=True):
        init(self, scale, window, spike_nt, native)
        self.push = _w4(self.push, SCREEN, OUTPUT)
    return w


def _acquisition(init):
    """Acquisition.__init__ that wraps the ring's reader in the instance, where a native one
    (drdy.Drain) lives: the samples it delivers are the survey output's, less the screen's."""
    def w(self, *a, **k):
        init(self, *a, **k)
        self.poll = _w3(self.poll, OUTPUT, REST)   # bound: (on_sample, limit, on_gap)
    return w


def _wrap(cls, name, wrapper, part, parent=None):
    setattr(cls, name, wrapper(getattr(cls, name), part, parent))


def _session_parts():
    """Wrap the parts in the modules a session imports (calibration_flow.py imports them at
    start-cal and drops them after the session, freeing their bytecode): imported here at boot
    they would stay, and the profiled firmware's heap ran out at start-cal (no_memory). Each
    session's fresh classes are wrapped once (the `_profiled` mark)."""
    m = sys.modules
    for cls, name, wrapper, part, parent in (
            (m["gates"].Gates, "sample", _w4, GATES, OUTPUT),             # ... then a session's gates,
            (m["shared.fit"].EllipsoidFit, "add", _w4, ADD, GATES),      # ... which add() what they accept
            (m["residuals"].ResidualBatches, "added", _w1, BATCHES, GATES),   # ... and count it into its batch
            (m["session"].Session, "_solve", _nested, SOLVE, None)):     # every solve_every_s, and the final one
        if not getattr(cls, "_profiled", False):
            _wrap(cls, name, wrapper, part, parent)
    for cls in (m["gates"].Gates, m["shared.fit"].EllipsoidFit, m["residuals"].ResidualBatches, m["session"].Session):
        cls._profiled = True


def _start(start):
    def w(flow, *a, **k):
        r = start(flow, *a, **k)
        _session_parts()
        s = flow.session
        if s is not None:
            s.sample = s.gates.sample   # session.py binds the gates' sample when it is built
        return r
    return w


_wrap(survey.Output, "sample", _w5, OUTPUT, REST)          # per sample: |h_c|, the block, the data event
acquisition.Acquisition.__init__ = _acquisition(acquisition.Acquisition.__init__)   # ... from the ring's reader
_wrap(app.App, "wait", _w1, SLEEP, REST)                  # the pass's sleep: its wake-ups at each interrupt
_wrap(button.Button, "poll", _w1, HOUSE, REST)            # polled every pass: the button,
_wrap(led.Led, "update", _w1, HOUSE, REST)                # ... the LED,
_wrap(health.AdcSupervisor, "check", _w2, HOUSE, REST)    # ... the ADC's health
screen.Screen.__init__ = _screen(screen.Screen.__init__)    # ... first the spike screen,
calibration_flow.CalibrationFlow.start = _start(calibration_flow.CalibrationFlow.start)   # ... a session's parts
_wrap(protocol.Protocol, "poll", _w1, PROTOCOL, REST)      # the serial line: read, parse, answer
_wrap(calibration_flow.CalibrationFlow, "tick", _w1, TICK, REST)   # a session's pass: progress, LED, solves
_wrap(calibration_flow.CalibrationFlow, "finish", _nested, FINISH)   # the checks, tempco, the save
app.start(hal_micropython)
