"""The application: ADC -> ring -> (calibration session | survey), button, LED, serial.

    App(board).run()      # main.py / code.py / the simulators all end here

One cooperative main loop, no threads: drain the DRDY ring, feed each
decimated sample to the calibration session and the survey averager, poll the
button and the serial line, drive the LED, then idle for _HOUSE_MS. The DRDY
handler does the boxcar itself and the ring holds 1.28 s of samples, so a pass
runs every _HOUSE_MS whatever the rates: the button, serial and LED work of a
pass (~35k instructions on a Cortex-M, docs/firmware.md) is paid 50 times a
second, not once per sample.
The serial commands are commands.py; every state a user can see is also in
their `status`.

Nothing stops the loop (docs/reliability.md): an exception in a pass is
counted, reported (status, an `error` event) and the loop goes on; a
calibration session it interrupts is cancelled. ADC faults after boot are
named by health.py and re-probed until they clear; samples that cannot be the
field are screened out (screen.py); boots that never become healthy bring the
next one up in safe mode (bootguard.py).
"""

import gc

import bootguard
import commands
import config as cfgmod
import store
from acquisition import Acquisition
from ads1292 import ADS1292Pair
from button import Button, SHORT, LONG
from health import Health
from led import Led
import led as ledp
from protocol import VERSION, Protocol, ProtocolError, json_number
from screen import Screen
from survey import Survey, RotatingLog
from shared.calibration import Calibration
from session import AUTO, FULL, KINDS, QUICK, Session

FIRMWARE_VERSION = "0.1.0"
_DRAIN = 16      # samples per loop pass at least (more when more arrive per pass)
_HOUSE_MS = 20   # a pass every 20 ms: button (debounce is 30 ms), serial, LED, samples
# board.busy keys: the main loop's work, charged as simulated time by hal_sim
_SOLVE = "solve"
_SAMPLE_CAL = "sample_cal"
_SAMPLE = "sample"
_ERROR_EVENT_MS = 1000   # at most one `error` event a second (all are counted)
_SAFE_AFTER_ERRORS = 50  # passes in a row failing with a calibration applied: drop it (safe mode)
# re-apply the temperature coefficients when the die moved this much: at 20 ppm/C and
# 1 nT/C a step of 0.05 nT at 48,000 nT, below the noise
_TEMP_STEP_C = 0.05
# the coefficients hold a little beyond the temperatures they were measured at (each a
# calibration's mean die reading): warn only this far outside their range
_RANGE_MARGIN_C = 1.0
_EXTRAPOLATE_C = 10.0     # and are applied at most this far outside it (held there beyond)


class App:
    firmware = FIRMWARE_VERSION

    def __init__(self, board):
        self.board = board
        self.proto = Protocol(board, commands.TABLE, self)
        self.button = Button(board)
        self.led = Led(board)
        self.session = None
        self.last_coverage = None
        self.last_result = None
        self.fault = None
        self.temp_c = None
        self.cal_temp_warn = False
        self.log = None
        self.last_progress = board.ticks_ms()
        self.boot_ms = board.ticks_ms()
        self.quit = False
        self._sample_cb = self._on_sample  # bound once: no allocation per loop pass
        self._diff = board.ticks_diff
        self._gap_cb = self._on_gap
        self._want_f = False
        self.cal_w = None
        self.cal_now = None      # the calibration at the die temperature (tempco applied)
        self._comp_temp = None
        self.errors = 0            # exceptions caught in the main loop since boot
        self.last_error = None
        self._errors_in_row = 0
        self._error_event_ms = None
        self.fault_code = None
        self._last_code = None
        self.health = None
        self.clipped_warned = False
        starts, crash = bootguard.begin(board.root)
        self.safe_mode = bootguard.safe_reason(starts, crash)
        self._healthy = False
        body, _src, problem = store.load(board.root, "config")
        self.cfg, self.config_problems = cfgmod.from_dict(body if body is not None else {})
        if problem:
            self.config_problems.append(problem)
        self.stream = self.cfg["stream"]
        self._load_cal()
        self.acq = Acquisition(board, self.cfg["decim"], self.cfg["window"])
        self.adc = None
        self._reprobe_at = None
        self._verifying = False
        self._start_adc()
        self._setup_pipeline()
        self.proto.event("boot", {"fw": FIRMWARE_VERSION, "proto": VERSION, "calibrated": self.cal is not None,
                                  "cal_source": self.cal_source, "fault": self.fault,
                                  "safe_mode": self.safe_mode})

    # ****** setup ******
    def _load_cal(self):
        body, src, problem = store.load(self.board.root, "cal", Calibration.from_dict)
        self.cal = Calibration.from_dict(body) if body is not None else None
        self.cal_w = None
        self.cal_source = src
        self.cal_problem = problem
        if self.safe_mode and self.cal is not None:
            # the record stays on the flash: clear-cal, set-cal or a healthy reboot decide
            self.cal = None
            self.cal_source = "stored, not applied: safe mode"

    def _start_adc(self, reprobe=False):
        """Probe and start the chips (a re-probe resets them first), or reconfigure running ones."""
        c = self.cfg
        gains = (c["gain_x"], c["gain_y"], c["gain_z"])
        try:
            if self.adc is None:
                self.adc = ADS1292Pair(self.board, self.acq, c["rate"], gains, c["vref_4v"])
                self.adc.begin()
            elif reprobe:
                self.adc.begin()
            else:
                self.adc.reconfigure(c["rate"], gains)
            # again after a reconfigure: a polling HAL restarts its gap clock at the new rate
            self.board.attach_drdy(self.acq.isr, self.adc.rate, self.acq.account_gap)
            now = self.board.ticks_ms()
            if self.health is None:
                self.health = Health(self.acq, self.adc.rate, now)
            else:
                self.health.rate_changed(self.adc.rate, now)
            # a chip that failed answers again: it is cleared once conversions flow healthy
            # for a check period (health.py), not on its registers alone (a stuck DRDY
            # passes a probe)
            self._verifying = self.fault is not None
        except OSError as e:
            self._verifying = False
            self._set_fault("adc_probe", str(e))

    def _setup_pipeline(self):
        c = self.cfg
        if (c["decim"], c["window"]) != (self.acq.decim, self.acq.window):
            self.acq.set_decimation(c["decim"], c["window"])   # counters from zero: a new boxcar
        if self.health is not None:
            self.health.rate_changed(c["rate"], self.board.ticks_ms())
        self.sample_hz = c["rate"] / c["decim"]
        self._house_idles = max(1, c["rate"] * _HOUSE_MS // 1000)
        # twice what a pass brings: a pass that ran late catches up in the next
        self._drain = max(_DRAIN, 2 * (self._house_idles // c["decim"] + 1))
        self.survey = Survey(c, c["window"], self.sample_hz)
        self.scale = (c["scale_x"], c["scale_y"], c["scale_z"])
        self.screen = Screen(self.scale, c["window"], c["spike_nt"])
        if c["log"] and self.log is None:
            self.log = RotatingLog(self.board.root, c["log_file_bytes"], c["log_files"], c["log_reserve_bytes"])
        elif not c["log"] and self.log is not None:
            self.log.close()
            self.log = None
        self._outputs()
        if not self.fault:
            self._steady_led()

    def _outputs(self):
        # |h_c| per sample is only needed when a block goes out (stream or log);
        # the calibration in sum units saves three divisions per sample
        want = self.stream != "off" or self.log is not None
        if want and not self._want_f:
            self.survey.restart()   # the open block's samples carry no |h_c|: start a new one
        self._want_f = want
        self._compensate(self.temp_c, True)

    def _compensate(self, temp, force=False):
        """The calibration at the die temperature (its tempco applied; docs/temperature.md),
        recomputed when the temperature moved by _TEMP_STEP_C: about 40 float operations."""
        cal = self.cal
        if cal is not None and cal.tempco is not None and temp is not None:
            # linear beyond the measured range for a few degrees, held there after: a die
            # reading far off (a fault, a hot spot) must not extrapolate the drift without end
            lo, hi = cal.tempco["range_c"]
            temp = min(max(temp, lo - _EXTRAPOLATE_C), hi + _EXTRAPOLATE_C)
            if not force and self._comp_temp is not None and abs(temp - self._comp_temp) < _TEMP_STEP_C:
                return
            self._comp_temp = temp
            cal = cal.at_temperature(temp)
        elif not force:
            return
        self.cal_now = cal
        self.cal_w = cal.scaled_input(self.cfg["window"]) if cal is not None else None

    # ****** main loop ******
    def run(self):
        b = self.board
        while not self.quit and not b.quit_requested():
            try:
                self.step()
                self._errors_in_row = 0
            except Exception as e:  # noqa: BLE001 - nothing stops the instrument (docs/reliability.md)
                self._loop_error(e)
            if not self._healthy and self._errors_in_row == 0 and \
                    b.ticks_diff(b.ticks_ms(), self.boot_ms) >= bootguard.HEALTHY_MS:
                self._healthy = True
                bootguard.healthy(b.root)
            self.wait()
        if self.log is not None:
            self.log.close()
        b.hand_back()   # `repl` (self.quit): main.py / code.py ends next, the REPL takes the line

    def wait(self):
        """Idle for _HOUSE_MS, counted in conversions.

        idle() returns after every DRDY (the IRQ wakes the core), so the loop
        counts DRDY periods instead of reading the clock. It runs once per
        conversion (2000 times a second at the default rate), so a wake-up costs
        one decrement and the HAL's idle() (machine.idle itself on MicroPython,
        a poll of the DRDY pin on CircuitPython), nothing else. A quit request
        (simulators) is seen by run() within _HOUSE_MS.
        """
        b = self.board
        if self.fault:   # no conversions to count: by the clock
            t0 = b.ticks_ms()
            while not b.quit_requested():
                b.idle()
                if b.ticks_diff(b.ticks_ms(), t0) >= _HOUSE_MS:
                    return
            return
        n = self._house_idles
        idle = b.idle
        while n > 0:
            idle()
            n -= 1

    def _loop_error(self, e):
        """An exception escaped a pass: count it, say it, cancel what it interrupted, go on."""
        self.errors += 1
        self._errors_in_row += 1
        self.last_error = "%s: %s" % (e.__class__.__name__, e)
        if isinstance(e, MemoryError):
            gc.collect()
        b = self.board
        now = b.ticks_ms()
        if self._error_event_ms is None or b.ticks_diff(now, self._error_event_ms) >= _ERROR_EVENT_MS:
            self._error_event_ms = now
            self.proto.event("error", {"where": "main_loop", "error": self.last_error[:200], "count": self.errors})
        if self.session is not None:
            s = self._end_session()
            s.cancel()
            s.reason = "internal_error"
            s.message = self.last_error[:200]
            self.last_result = {"state": s.state, "reason": s.reason, "msg": s.message}
            self.proto.event("cal", self.last_result)
            self.led.flash(ledp.FAILED)
        if self._errors_in_row >= _SAFE_AFTER_ERRORS and self.cal is not None:
            # defence in depth: validation should make this unreachable
            self.safe_mode = "the main loop failed %d times in a row with the calibration applied: %s" % (
                self._errors_in_row, self.last_error[:120])
            self.cal = None
            self.cal_source = "stored, not applied: safe mode"
            self._outputs()
            self._steady_led()
            self.proto.event("safe_mode", {"reason": self.safe_mode})

    def _set_fault(self, code, msg):
        b = self.board
        now = b.ticks_ms()
        first = self.fault is None
        self.fault = msg
        self.fault_code = code
        if self.health is not None and first:
            self.health.fault_seen(now, b.ticks_diff)
        self._reprobe_at = now
        self.led.set(ledp.FAULT)
        if first or code != self._last_code:
            self.proto.event("fault", {"code": code, "msg": msg})
        self._last_code = code
        if self.session is not None:
            s = self._end_session()
            s.cancel()
            s.reason = "fault"
            s.message = msg
            self.last_result = {"state": s.state, "reason": "fault", "msg": msg}
            self.proto.event("cal", self.last_result)

    def _check_adc(self, now):
        """Health of a running ADC; re-probe a faulty one every health.reprobe_ms."""
        b = self.board
        if self.fault and not self._verifying:
            ms = self.health.reprobe_ms if self.health is not None else 2000
            if self._reprobe_at is None or b.ticks_diff(now, self._reprobe_at) >= ms:
                self._reprobe_at = now
                self._start_adc(reprobe=True)
            return
        if self.health is None:
            return
        problem = self.health.check(now, b.ticks_diff)
        if problem is not None:
            self._verifying = False
            self._set_fault(problem[0], problem[1])
        elif self._verifying and self.health.flowing:
            self._verifying = False
            self.health.cleared(now)
            self.proto.event("fault", {"code": None, "cleared": self.fault_code})
            self.fault = None
            self.fault_code = None
            self._reprobe_at = None
            self._setup_pipeline()

    def step(self):
        b = self.board
        if not self.fault or self._verifying:
            n = self.acq.poll(self._sample_cb, self._drain, self._gap_cb)
            if n:
                b.busy(_SAMPLE_CAL if self.session is not None else _SAMPLE, n)
        self._check_adc(b.ticks_ms())
        ev = self.button.poll()
        if ev is not None and self.session is None:
            # idle: a short press starts a calibration (auto: quick or full by the coverage
            # reached), a long one a quick re-calibration (docs/firmware.md, the button)
            try:
                self.start_session(AUTO if ev == SHORT else QUICK)
            except ProtocolError as e:
                self.proto.event("cal", {"state": "failed", "reason": e.code, "msg": str(e)})
                self.led.flash(ledp.FAILED)
        elif ev == SHORT:
            self.finish_session()
        elif ev == LONG:
            self.cancel_session()
        self.proto.poll()
        s = self.session
        if s is not None:
            now = b.ticks_ms()
            solved = s.tick(now, self._diff)
            if solved:
                b.busy(_SOLVE)
            if b.ticks_diff(now, self.last_progress) >= 1000:
                self.last_progress = now
                self.proto.event("cal", s.progress(True))
                if not s.ready():
                    self.led.set(ledp.SLOW_DOWN if s.slow_down else ledp.COLLECTING)
            # coverage is a pass over all cells: check it only after a provisional solve
            if solved and s.ready():
                self.led.set(ledp.ENOUGH)
                if self.cfg["auto_finish"]:
                    self.finish_session()
            elif s.timed_out(now, self._diff):
                self.finish_session()
        self.led.update()

    def _on_gap(self):
        self.screen.reset()
        if self.session is not None:
            self.session.break_chain()

    def _on_sample(self, rx, ry, rz, rt):
        sc = self.screen
        clipped = sc.clipped
        if not sc.push(rx, ry, rz, rt):
            if sc.clipped != clipped and self.session is not None:
                self.session.clipped += 1
                self.session.clip_axis = sc.clip_axis
            return
        sx = sc.x
        sy = sc.y
        sz = sc.z
        st = sc.t
        s = self.session
        if s is not None:
            s.sample(sx, sy, sz)
        # |h_c| per decimated sample, averaged over the output block (rotation invariant)
        if self._want_f:
            cal = self.cal_w
            if cal is not None:
                f = cal.magnitude(sx, sy, sz)
            else:
                k = self.scale
                f = ((sx * k[0]) ** 2 + (sy * k[1]) ** 2 + (sz * k[2]) ** 2) ** 0.5 / self.cfg["window"]
        else:
            f = 0.0
        blk = self.survey.sample(sx, sy, sz, st, f)
        if blk is not None:
            self._output(blk)

    def _output(self, blk):
        x, y, z, tc, f = blk
        temp = self.adc.temperature_c(tc)
        self.temp_c = temp
        if self.session is not None:
            self.session.add_temperature(temp)   # one per block: the die changes over seconds
        self._compensate(temp)
        cal = self.cal_now
        tcal = None
        warn = False
        msg = None
        if cal is not None and self.cal.tempco is not None:
            # compensated: a warning only outside the range the coefficients were measured over
            lo, hi = self.cal.tempco["range_c"]
            warn = temp < lo - _RANGE_MARGIN_C or temp > hi + _RANGE_MARGIN_C
            if warn:
                msg = "temperature %.1f C outside the compensated %.1f..%.1f C" % (temp, lo, hi)
        elif cal is not None:
            tcal = cal.meta.get("temperature_c")
            warn = tcal is not None and abs(temp - tcal) > self.cfg["temp_warn_c"]
            if warn:
                msg = "temperature %.1f C differs from calibration %.1f C" % (temp, tcal)
        self.cal_temp_warn = warn
        if not self._want_f:
            return   # nothing goes out: no stream, no log
        t = self.board.ticks_ms()
        if cal is not None:
            bx, by, bz = cal.correct(x, y, z)
        else:
            k = self.scale
            bx, by, bz = x * k[0], y * k[1], z * k[2]
        r = json_number
        if self.stream == "corrected":
            self.proto.event("data", {"t": t, "b": [r(bx), r(by), r(bz)], "f": r(f), "temp": r(temp, 2),
                                      "c": [r(x, 2), r(y, 2), r(z, 2)], "cal": cal is not None, "warn": msg})
        elif self.stream == "raw":
            self.proto.event("raw", {"t": t, "c": [r(x, 2), r(y, 2), r(z, 2)], "temp": r(temp, 2)})
        if self.log is not None and self.session is None:
            self.log.write("%d,%.3f,%.3f,%.3f,%.3f,%.2f\n" % (t, bx, by, bz, f, temp))

    # ****** calibration flow (the button and commands.py both drive it) ******
    def start_session(self, kind=AUTO):
        if self.session is not None:
            raise ProtocolError("busy", "calibration already in progress")
        if self.fault:
            raise ProtocolError("fault", "ADC fault (%s): %s" % (self.fault_code, self.fault))
        if kind not in KINDS:
            raise ProtocolError("bad_argument", "kind must be auto, full or quick")
        if kind == QUICK and self.cal is None:
            raise ProtocolError("no_calibration", "a quick re-calibration needs a calibration in force: run a full one")
        c = self.cfg
        period_ms = 1000.0 * c["decim"] / c["rate"]
        # the previous calibration as it stands now (its temperature coefficients applied)
        prior = None if kind == FULL else self.cal_now
        gc.collect()   # the session's buffers want a few contiguous KB of a small heap
        self.session = Session(c, self.scale, c["window"], period_ms, prior, self.board.ticks_ms(), kind)
        self.last_progress = self.board.ticks_ms()
        self.led.set(ledp.COLLECTING)
        self.proto.event("cal", self.session.progress())

    def finish_session(self):
        s = self._end_session()
        gc.collect()
        cal, reason, msg = s.finish()
        self.board.busy(_SOLVE)
        result = {"state": s.state, "n": s.fit.n, "coverage": json_number(s.coverage())}
        if cal is None:
            result["reason"] = reason
            result["msg"] = msg
            self.led.flash(ledp.FAILED)
        else:
            cal.meta["firmware"] = FIRMWARE_VERSION
            cal.meta["uptime_ms"] = self.board.ticks_diff(self.board.ticks_ms(), self.boot_ms)
            t = self.board.time()
            if t is not None:
                cal.meta["time"] = t
            cal.meta["rate"] = self.cfg["rate"]
            cal.meta["scale"] = list(self.scale)
            cal, result["tempco"] = self._with_tempco(cal)
            saved, err = self.install(cal)
            result["saved"] = saved
            if err:
                result["save_error"] = err
            d = cal.diagnostics
            for k in ("rms", "predicted_error", "observability"):
                result[k] = json_number(d.get(k), 4)
            result["field"] = json_number(cal.field, 2)
            result["kind"] = cal.meta.get("kind")
            self.led.flash(ledp.DONE if result["kind"] == FULL else ledp.DONE_QUICK)
        self.last_result = result
        self.proto.event("cal", result)
        self._steady_led()
        return result

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

    def cancel_session(self):
        s = self._end_session()
        s.cancel()
        self.last_result = {"state": s.state, "reason": s.reason, "msg": s.message}
        self.proto.event("cal", self.last_result)
        self.led.flash(ledp.FAILED)
        self._steady_led()

    def _end_session(self):
        s = self.session
        if s is None:
            raise ProtocolError("not_calibrating", "no calibration in progress")
        self.session = None
        self.last_coverage = s.cov
        return s

    def _steady_led(self):
        if self.fault:
            self.led.set(ledp.FAULT)
        elif self.safe_mode:
            self.led.set(ledp.SAFE)
        else:
            self.led.set(ledp.SURVEY if self.cal is not None else ledp.UNCALIBRATED)

    def _leave_safe_mode(self):
        """The operator chose a calibration (set-cal, clear-cal, a new one): safe mode has done its job."""
        if self.safe_mode:
            self.safe_mode = None
            bootguard.healthy(self.board.root)

    def install(self, cal):
        """Make cal the active calibration and store it; (saved, error)."""
        self._leave_safe_mode()
        self.cal = cal
        self._outputs()
        self.cal_source = "new"
        self.cal_problem = None
        self._steady_led()
        try:
            store.save(self.board.root, "cal", cal.to_dict())
            return True, None
        except MemoryError:   # the record is active; the old file stays until a save succeeds
            return False, "no memory to write cal.json"
        except (OSError, ValueError) as e:   # ValueError: a store older than its OSError contract
            return False, str(e) or e.__class__.__name__

    def clear_calibration(self):
        """Forget the calibration, on the flash first: OSError (read-only, ...) leaves it in force,
        so what the next boot loads is what the device says now."""
        store.remove(self.board.root, "cal")
        self._leave_safe_mode()
        self.cal = None
        self._outputs()
        self.cal_source = None
        self._steady_led()

    # ****** settings (commands.py) ******
    def set_stream(self, mode):
        self.stream = mode
        self._outputs()

    def apply_config(self, new):
        """Make a validated configuration current: saved first, then applied."""
        store.save(self.board.root, "config", cfgmod.changed(new))
        old = self.cfg
        self.cfg = new
        if new["stream"] != old["stream"]:
            self.stream = new["stream"]
        if new["rate"] != old["rate"] or (new["gain_x"], new["gain_y"], new["gain_z"]) != \
                (old["gain_x"], old["gain_y"], old["gain_z"]):
            self._start_adc()
        self._setup_pipeline()


def start(hal):
    """Boot on real hardware: config.json -> hal.Board(cfg) -> App, unless the button is held.

    An exception that escapes the app anyway (its constructor, a HAL) is written to
    boot.txt before it reaches the REPL: the next boot comes up in safe mode."""
    body, _src, _problem = store.load("", "config")
    cfg, _problems = cfgmod.from_dict(body or {})
    board = hal.Board(cfg)
    if board.button():
        print("fluxcal: button held at boot, staying in the REPL")
        return None
    try:
        App(board).run()
    except Exception as e:
        bootguard.crashed(board.root, "%s: %s" % (e.__class__.__name__, e))
        raise
