"""The calibration flow the button and the serial commands share: start, finish, cancel, install, clear.

    flow = CalibrationFlow(board, proto, led, output, guard, supervisor, firmware)   # app.py wires it
    flow.load()             # the stored calibration, at boot (not applied in safe mode)
    flow.configure(cfg)
    flow.press(ev)          # the button: idle, a short press starts (auto), a long one a quick one;
                            # calibrating, a short press finishes, a long one cancels
    flow.tick()             # every main-loop pass while calibrating: solves, progress, the LED
    flow.start(kind, hold) / finish() / cancel() / install(cal) / clear()   # start-, finish-, cancel-, set-, clear-cal
    flow.status()           # its part of `status`

It owns the calibration in force (`cal`, where it came from, why a stored one was not loaded) and the
session in progress (session.py), and shows them on the LED: COLLECTING (keep rotating), SLOW_DOWN (turning
faster than the gate), ENOUGH (press to finish), DONE / DONE_QUICK / FAILED once, then the steady pattern
(FAULT, SAFE, SURVEY or UNCALIBRATED; led.py). A new calibration gets temperature coefficients fitted against the
one it replaces when their die temperatures are tempco_min_span_c apart, else the previous ones carried over
(docs/temperature.md). A session ends early with reason "fault" (health.py) or "internal_error" (bootguard.py);
a start or a finish the heap cannot hold fails with "no_memory", the calibration in force kept.
"""

import gc
import sys
from array import array

import led as ledp
import store
from button import LONG, SHORT
from protocol import ProtocolError, json_number
from session_modules import drop_modules, sums_path
from shared import codes
from shared.calibration import Calibration
from shared.codes import AUTO, FULL, QUICK

KEEP_CAL = "keep-cal"
SOLVE = "solve"   # board.busy key: a solve, charged as simulated time by the simulated board
KINDS = (AUTO, FULL, QUICK)   # start-cal's (the session's states and kinds: shared/codes.py)
HIST_INTS = 5 * 256           # gates.py's hist (5 ints x HIST), a session's largest block (start)
_NO_MEMORY = "the board's heap is short: the calibration in force stays (a power cycle frees it)"


class CalibrationFlow:
    def __init__(self, board, proto, led, output, guard, supervisor, firmware):
        self.board = board
        self.proto = proto
        self.led = led
        self.output = output
        self.guard = guard
        self.supervisor = supervisor
        self.firmware = firmware
        self.cfg = None
        self.scale = None
        self.session = None
        self.last_coverage = None
        self.last_result = None
        self.last_progress = board.ticks_ms()
        self.cal = None
        self.cal_source = None
        self.cal_problem = None
        self.held = None          # a full calibration predicted worse than the one in force (keep-cal)
        self._diff = board.ticks_diff
        self._resident = None     # sys.modules before the session in progress imported its own
        self._sums_path = sums_path()
        self.linalg_path = "python"   # the solver's float kernels: app.py's float_kernels() at boot
        self.service = None       # app.py: the ring drained, the watchdog fed (between the finish's solves)

    def load(self):
        body, src, problem = store.load(self.board.root, "cal", Calibration.from_dict)
        self.cal = Calibration.from_dict(body) if body is not None else None
        self.cal_source = src
        self.cal_problem = problem
        if self.guard.safe_mode and self.cal is not None:
            # the record stays on the flash: clear-cal, set-cal or a healthy reboot decide
            self.cal = None
            self.cal_source = "stored, not applied: safe mode"
        self.output.use(self.cal)

    def configure(self, cfg):
        self.cfg = cfg
        self.scale = (cfg["scale_x"], cfg["scale_y"], cfg["scale_z"])

    # ****** the session ******
    def press(self, ev):
        if self.session is None:
            # idle: a short press starts one (auto: quick or full by the coverage), a long one a quick one
            try:
                self.start(AUTO if ev == SHORT else QUICK)
            except ProtocolError as e:
                self.proto.event("cal", {"state": codes.FAILED, "reason": e.code, "msg": str(e)})
                self.led.flash(ledp.FAILED)
        elif ev == SHORT:
            self.finish()
        elif ev == LONG:
            self.cancel()

    def tick(self):
        # most passes end here (~60 k cycles less on an RP2040): nothing is due before _quiet_ms from _quiet_from
        # (_tick). The finish runs outside _tick's frame, which would keep the session and its bytecode on the heap
        now = self.board.ticks_ms()
        if self._diff(now, self._quiet_from) < self._quiet_ms:
            return
        if self._tick(now):
            self.finish()

    def _tick(self, now):
        """The session's pass: its solve, progress and LED; True when it is to finish."""
        s = self.session
        b = self.board
        solved = s.tick(now, self._diff)
        if solved:
            b.busy(SOLVE)
        if b.ticks_diff(now, self.last_progress) >= 1000:
            self.last_progress = now
            self.proto.event("cal", s.progress(True))
            if not s.ready():
                self.led.set(ledp.SLOW_DOWN if s.slow_down else ledp.COLLECTING)
        # coverage is a pass over all cells: check it only after a provisional solve
        if solved and s.ready():
            self.led.set(ledp.ENOUGH)
            return self.cfg["auto_finish"] and not s.hold
        self._quiet_from = now   # nothing due until the next solve (or check for one), progress, timeout
        self._quiet_ms = min(s.next_check_ms(now, self._diff), 1000 - b.ticks_diff(now, self.last_progress))
        return s.timed_out(now, self._diff)

    def start(self, kind=AUTO, hold=False):
        if self.session is not None:
            raise ProtocolError(codes.BUSY, "calibration already in progress")
        sup = self.supervisor
        if sup.fault:
            raise ProtocolError(codes.FAULT, "ADC fault (%s): %s" % (sup.fault_code, sup.fault))
        if kind not in KINDS:
            raise ProtocolError(codes.BAD_ARGUMENT, "kind must be auto, full or quick")
        if kind == QUICK and self.cal is None:
            raise ProtocolError(codes.NO_CALIBRATION, "a quick re-calibration needs a calibration in force: run a full one")
        c = self.cfg
        # the previous calibration as it stands now (its temperature coefficients applied)
        prior = None if kind == FULL else self.output.cal_now
        self.held = None   # a calibration refused as worse is kept until the next session
        try:
            self._open(c, kind, hold, prior)
        except MemoryError:
            # a heap in pieces (the .mpy firmware's on a small board: docs/limits.md): nothing half
            # made stays, the session's modules neither, and the button's press says why (press)
            if self.session is not None:
                self._end()
            self._unload()
            gc.collect()
            raise ProtocolError(codes.NO_MEMORY, _NO_MEMORY)

    def _open(self, c, kind, hold, prior):
        period_ms = 1000.0 * c["decim"] / c["rate"]
        if self._resident is None:
            self._resident = set(sys.modules)
        gc.collect()   # the session's largest block, the gates' hist, taken before its modules load into the holes
        hist = array("i", range(HIST_INTS))
        from session import Session
        from shared.fit import SUMS_PATH
        gc.collect()
        self._sums_path = SUMS_PATH
        if self.linalg_path == "native":   # the float kernels app.py loaded, for this session's shared.linalg
            from shared import linalg_native
            linalg_native.install()
        self.session = Session(c, self.scale, c["window"], period_ms, prior, self.board.ticks_ms(), kind, hold,
                               self.board.polls_drdy, hist)
        self.output.session = self.session
        self.output.respond()   # its samples de-lagged with the session's response
        # its own conversions only: the screen's and de-lag's held samples let go (tests/micropython/two_sessions.py)
        self.output.gap()
        self.last_progress = self._quiet_from = self.board.ticks_ms()
        self._quiet_ms = 0          # tick(): nothing due for this long from _quiet_from (the first pass: all due)
        self.led.set(ledp.COLLECTING)
        self.proto.event("cal", self.session.progress())

    def finish(self):
        s = self._end()
        if self.service is not None:
            s.between, s.service = self._between, self.service
        gc.collect()
        cal = result = held = None
        try:
            cal, result, held = self._conclude(s)
        except MemoryError:
            pass        # refused below, once the session's heap is back: the calibration in force stays
        finally:
            # the session and its modules collected first: the calibration's objects go where it was, packed
            s = None
            self._unload()
            gc.collect()
        if result is None:
            result = {"state": codes.FAILED, "reason": codes.NO_MEMORY, "msg": _NO_MEMORY}
        return self._settle(cal, result, held)

    def _between(self):
        """After each of the tau estimate's solves at the finish: its time charged, then the main loop's service."""
        self.board.busy(SOLVE)
        self.service()

    def _conclude(self, s):
        """The session's result: (calibration or None, the cal event's fields, held: see _worse_than_current)."""
        cal, reason, msg = s.finish()
        b = self.board
        # and the tau estimate's (lagfit.py), unless charged one by one in _between
        b.busy(SOLVE, 1 if s.between is not None else 1 + s.search_solves)
        result = {"state": s.state, "n": s.fit.n, "coverage": json_number(s.coverage())}
        held = None
        if cal is None:
            result["reason"] = reason
            result["msg"] = msg
        else:
            cal.meta["firmware"] = self.firmware
            cal.meta["uptime_ms"] = self.guard.uptime_ms()
            t = b.time()
            if t is not None:
                cal.meta["time"] = t
            cal.meta["rate"] = self.cfg["rate"]
            cal.meta["scale"] = list(self.scale)
            cal, result["tempco"] = self._with_tempco(cal)
            d = cal.diagnostics
            for k in ("rms", "predicted_error", "observability"):
                result[k] = json_number(d.get(k), 4)
            result["field"] = json_number(cal.field, 2)
            result["kind"] = cal.meta.get("kind")
            held = self._worse_than_current(cal, s)
        return cal, result, held

    def _settle(self, cal, result, held):
        """Put the session's calibration in force (saved), or hold it, or say it failed."""
        if cal is None:
            self.led.flash(ledp.FAILED)
        elif held is not None:
            # the one in force stays; the new one waits for keep-cal (until the next session or boot)
            self.held = cal
            result["state"] = codes.FAILED
            result["reason"] = codes.WORSE_THAN_CURRENT
            result["msg"] = ("predicted full-sphere error %.3f nT is not below the %.3f nT of the calibration in "
                             "force on these samples: it stays" % held)
            result["current_error"] = json_number(held[1], 4)
            result["in_force"] = False
            self.led.flash(ledp.KEPT_PREVIOUS)
        else:
            saved, err = self.install(cal)
            result["saved"] = saved
            if err:
                result["save_error"] = err
            result["in_force"] = True
            self.led.flash(ledp.DONE if result["kind"] == FULL else ledp.DONE_QUICK)
        self.last_result = result
        self.proto.event("cal", result)
        self.steady_led()
        return result

    def _worse_than_current(self, new, s):
        """(new, in force) predicted errors, nT, when a full calibration is predicted no better than
        the calibration in force is on today's samples (session.py no_better_than); else None."""
        cur = self.output.cal_now    # as the survey applies it: its temperature coefficients in
        if self.cal is None or cur is None or new.meta.get("kind", FULL) != FULL:
            return None
        return s.no_better_than(new, cur, self.cal.diagnostics.get("predicted_error"))

    def _with_tempco(self, new):
        """new with temperature coefficients: fitted against the calibration it replaces when
        their temperatures are tempco_min_span_c apart, else the previous ones carried over.
        Returns (calibration, "fitted" / "kept" / None)."""
        prev = self.cal
        t_new = new.meta.get("temperature_c")
        if prev is None or t_new is None:
            return new, None
        from shared import tempco   # here: its bytecode is heap on a board without frozen modules
        t_prev = prev.meta.get("temperature_c")
        if t_prev is not None and abs(t_new - t_prev) >= self.cfg["tempco_min_span_c"]:
            try:
                return tempco.attach(new, tempco.fit_tempco([prev, new])), "fitted"
            except ValueError as e:   # not the same sensor or unit: no coefficients, said so
                self.proto.event("error", {"msg": "temperature coefficients not fitted: %s" % e})
                return new, None
        if prev.tempco is not None:
            return tempco.attach(new, prev.tempco), "kept"
        return new, None

    def cancel(self):
        s = self._end()
        self._unload()
        s.cancel()
        self.last_result = {"state": s.state, "reason": s.reason, "msg": s.message}
        self.proto.event("cal", self.last_result)
        self.led.flash(ledp.FAILED)
        self.steady_led()

    def abort(self, reason, msg, flash=True):
        """End a session in progress, if any, for a fault or a main-loop error: said as a cal
        event; flash: the FAILED pattern (a fault shows its own)."""
        if self.session is None:
            return
        s = self._end()
        self._unload()
        s.cancel()
        s.reason = reason
        s.message = msg
        self.last_result = {"state": s.state, "reason": reason, "msg": msg}
        self.proto.event("cal", self.last_result)
        if flash:
            self.led.flash(ledp.FAILED)

    def _end(self):
        s = self.session
        if s is None:
            raise ProtocolError(codes.NOT_CALIBRATING, "no calibration in progress")
        self.session = None
        self.output.session = None
        self.output.respond()
        self.last_coverage = s.cov
        return s

    def _unload(self):
        """Drop the modules the session brought (start), and any imported since by another path
        (tempco at the finish, acceptance for set-cal): session_modules.py."""
        resident, self._resident = self._resident, None
        if resident is not None:
            drop_modules(resident)

    def steady_led(self):
        if self.supervisor.fault:
            self.led.set(ledp.FAULT)
        elif self.guard.safe_mode:
            self.led.set(ledp.SAFE)
        else:
            self.led.set(ledp.SURVEY if self.cal is not None else ledp.UNCALIBRATED)

    # ****** the calibration in force ******
    def install(self, cal, by=None):
        """Make cal the active calibration and store it; (saved, error). by: the command that
        replaced the calibration in force (set-cal, keep-cal), said in the last result."""
        self.guard.leave()
        self.cal = cal
        self.output.use(cal)
        self.cal_source = "new"
        self.cal_problem = None
        if by is not None:
            self._replaced(by, by == KEEP_CAL)
        self.steady_led()
        try:
            store.save(self.board.root, "cal", cal.to_dict())
            return True, None
        except MemoryError:   # the record is active; the old file stays until a save succeeds
            return False, "no memory to write cal.json"
        except (OSError, ValueError) as e:   # ValueError: a store older than its OSError contract
            return False, str(e) or e.__class__.__name__

    def keep(self):
        """keep-cal: the calibration last refused as worse than the one in force, put in force; (saved, error)."""
        cal = self.held
        if cal is None:
            raise ProtocolError(codes.NO_CALIBRATION, "no calibration refused as worse since the last session")
        self.held = None
        return self.install(cal, KEEP_CAL)

    def _replaced(self, by, in_force):
        # status's last_cal says whether its calibration is the one in force now, and what changed it
        last = self.last_result
        if last is not None and "in_force" in last:
            last["in_force"] = in_force
            last["since"] = by
        if by != KEEP_CAL:
            self.held = None

    def clear(self):
        """Forget the calibration, on the flash first: OSError (read-only, ...) leaves it in force,
        so what the next boot loads is what the device says now."""
        store.remove(self.board.root, "cal")
        self.guard.leave()
        self._replaced("clear-cal", False)
        self.cal = None
        self.output.use(None)
        self.cal_source = None
        self.steady_led()

    def drop_calibration(self):
        """Safe mode entered while running (bootguard.py): the stored record stays, unapplied."""
        self.cal = None
        self.cal_source = "stored, not applied: safe mode"
        self.output.use(None)
        self.steady_led()

    def status(self):
        """Its part of `status`: the calibration in force, the last result, a session's progress."""
        cal = self.cal
        out = {
            "calibrated": cal is not None,
            "cal_source": self.cal_source,
            "cal_problem": self.cal_problem,
            # the kind that made the calibration in force, its temperature coefficients' range (None: none)
            "cal_kind": cal.meta.get("kind", FULL) if cal is not None else None,
            "tempco_range": cal.tempco["range_c"] if cal is not None and cal.tempco else None,
            "last_cal": self.last_result,
            # the fit's sums, the solver's float kernels: "native" (fitsums.mpy, linalgc.mpy) or "python"
            "sums": self._sums_path, "linalg": self.linalg_path,
        }
        if self.session is not None:
            out["cal"] = self.session.progress()
        return out
