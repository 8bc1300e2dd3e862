"""One calibration session: samples through the gates into the fit, provisional solves, the finish.

    s = Session(cfg, scale, window, period_ms, prior=None, now_ms=0, kind="auto", hold=False)
    s.sample(sx, sy, sz)           # each decimated sample (integer boxcar sums), through gates.py
    s.tick(now_ms, diff)           # provisional solve every solve_every_s
    s.ready()                      # coverage and predicted error reached
    cal, reason, msg = s.finish()  # cal in ADC-code units, or (None, reason, msg)

Kinds (start-cal quick|full|auto, docs/protocol.md): a full calibration fits
all nine parameters; a quick re-calibration (shared/quick.py) keeps the shape
of the calibration in force and fits its offsets and common gain from a
partial rotation, auto-finishing at quick_min_coverage; auto (the button's
short press) decides at the end: quick when a calibration is in force and the
coverage stayed under min_coverage, else full.

The fit runs on the full boxcar sums (code/window; exact integers, whose add costs the
same for 17- to 24-bit inputs); the accepted calibration is rescaled to ADC codes so it
survives a change of window. Which samples go in is gates.py's; whether the result may
be used, acceptance.py's (set-cal uses it too).
"""

import math

from acceptance import check_calibration
from gates import HIST, Gates, disturbance_limit
from shared import codes
from shared.codes import AUTO, CANCELLED, COLLECTING, DONE, FAILED, FULL, QUICK, RESHAPED
from shared.coverage import Coverage
from shared.delag import configured_tau_s, response_tau_s, sensor_is_slow, tau_us
from shared.fit import EllipsoidFit, FitError
from shared.response import check_response

_MIN_PROVISIONAL = 60
# Gauss-Newton steps of a provisional solve, which only sets the disturbance gate and says when
# coverage is enough: from the algebraic fit one step lands within 5e-5 nT of the converged fit on a
# 40 % cap, each further step ~4M instructions on a Cortex-M (docs/firmware.md). The final solve converges.
_PROVISIONAL_ITER = 1
_MAX_RHO = 0.999     # widening at most sqrt(1999) ~ 45x
CLIP_FRACTION = 200   # more than 1 in 200 samples clipped refuses the calibration


class Session:
    def __init__(self, cfg, scale, window, period_ms, prior=None, now_ms=0, kind="auto", hold=False, polled=False, hist=None):
        self.cfg = cfg
        # hold: finished by the operator (finish-cal, the button) or at max_cal_s, never at `ready`
        self.hold = hold
        self.kind = kind if prior is not None else FULL   # no calibration in force: only a full one
        self.window = window
        # nT per sum unit, per axis
        self.k = (scale[0] / window, scale[1] / window, scale[2] / window)
        self.period_ms = period_ms
        self.prior = prior.scaled_input(window) if prior is not None else None
        self.fit = EllipsoidFit()
        self.cov = Coverage(cfg["cells"], cfg["cell_cap"])
        self.c = [int(v) for v in self.prior.offset] if self.prior is not None else [0, 0, 0]
        # polled: the board polls DRDY (hal.py polls_drdy; shared/delag.py adc_delagged)
        self.gates = g = Gates(cfg, self.fit, self.cov, window, period_ms, self.c, polled, hist=hist)
        # the response the samples are de-lagged with (survey.py applies it), per axis in whole
        # us, and the record the calibration carries it in; None: not de-lagged (gates.py)
        tau = configured_tau_s(cfg, polled)
        self.taus_us = None if tau is None else [tau_us(tau)] * 3
        self.response = None if tau is None else {
            "model": "first-order", "tau_s": [t / 1e6 for t in self.taus_us], "source": "given",
            "tau_sigma_s": [cfg["response_tol"] * t / 1e6 for t in self.taus_us]}
        # the tau estimate (lagfit.py): the Delag's tau steps and the other nodes' sums (None:
        # not estimated), and the fit (and its unit) the finish solves
        self.steps_us = self.tau_sums = self._lagfit = None
        if self.taus_us is not None and cfg["tau_estimate"] and self.kind != QUICK and sensor_is_slow(cfg):
            # imported only where it runs: lagfit.py and shared/tausums.py are ~4 KB of a board's
            # heap as .mpy, which a quick re-calibration on a Pico's 190 KB has not to spare
            import lagfit
            self._lagfit = lagfit
            self.steps_us, self.tau_sums = lagfit.setup(cfg, self.taus_us, self.kind)
        self._final = None
        self.search_solves = 0      # the tau estimate's solves at the finish
        self.between = None         # called after each of them (calibration_flow.py: the main loop's service)
        self.service = None         # the main loop's service alone, after the finish's other long steps
        # bound once: the per-sample call allocates nothing
        self.sample = g.sample
        self.break_chain = g.break_chain
        self.gate_dps = g.gate_dps
        self.state = COLLECTING
        self.started = now_ms
        self.provisional_error = None
        self.solves = 0             # provisional solves run
        self.last_solve = now_ms
        self._solve_ms = cfg["solve_every_s"] * 1000
        self._max_ms = cfg["max_cal_s"] * 1000
        self.reason = None
        self.message = None
        self.temp_sum = 0.0
        self.temp_n = 0
        self.clipped = 0            # samples at the ADC's full scale (screen.py; not fitted)
        self.clip_axis = None
        self._fast_mark = 0          # rej_rate / seen at the last progress report
        self._seen_mark = 0
        self.slow_down = False       # most samples of the last report turned too fast
        self.turn_sd = 0.0           # sd of the squared turn between accepted samples (residual_rho)
        self.white = None            # the residuals' sample-to-sample noise, nT (residual_rho)
        self.tau_t = 0.0             # the samples' tau, in lagfit.py's steps from the configured one

    def elapsed_s(self, now_ms, diff):
        return diff(now_ms, self.started) / 1000.0

    def timed_out(self, now_ms, diff):
        return diff(now_ms, self.started) > self._max_ms

    def residual_rho(self, cal):
        """(rho, pairs, turn correlation) of the recent residuals' pairs (residual_stats.recent_pairs);
        keeps their white noise (the floor, _widen) and the spread of their squared turn (the
        tau term, _widen)."""
        import residual_stats    # after the solve, not with the session (residual_stats.py)
        rho, pairs, rate, white, turn_sd = residual_stats.recent_pairs(self.gates, cal)
        if white is not None:
            self.white = white
        if turn_sd is not None:
            self.turn_sd = turn_sd
        return rho, pairs, rate

    def recent_rms(self, cal):
        """(RMS of |h_c| - F in nT, n) over the last n <= HIST accepted samples under cal (in sum
        units): a calibration's misfit on today's samples, the new one's and the one in force's
        alike (calibration_flow.py compares them); (None, 0) without any."""
        g = self.gates
        h = g.hist
        n = g.hist_n
        if not n:
            return None, 0
        first = (g.hist_i - n) % HIST
        ss = 0.0
        for k in range(n):
            j = ((first + k) % HIST) * 5
            r = cal.magnitude(h[j], h[j + 1], h[j + 2]) - cal.field
            ss += r * r
        return math.sqrt(ss / n), n

    def no_better_than(self, new, cur, old):
        """(new, in force) predicted errors, nT, when the full calibration `new` (code units) is
        predicted no better than `cur`, the calibration in force (its own predicted error `old`),
        is on today's samples; else None. Here, not in calibration_flow.py: only a session runs it,
        and its modules leave the heap when it ends.

        On the session's last samples the one in force misfits by `stale`, the new one by `fresh`:
        stale^2 - fresh^2 is the mean square of their difference, the errors of both (e_prev^2 +
        e_new^2) and a drift D^2 since the one in force was made. Only a drift beyond three
        standard errors of that difference (2 fresh sqrt((stale^2 - fresh^2) / n)) counts: then the
        one in force is in error by sqrt(e_prev^2 + D^2) now, and a drifted sensor's new calibration
        replaces it even with fewer samples. A quick one was compared by the fit itself
        (not_better); one in force without a predicted error (set-cal) is no bar.
        """
        pe = new.diagnostics.get("predicted_error")
        if not isinstance(pe, (int, float)) or not isinstance(old, (int, float)):
            return None
        stale, n = self.recent_rms(cur.scaled_input(self.window))
        fresh, _ = self.recent_rms(new.scaled_input(self.window))
        if n:
            diff = stale * stale - fresh * fresh
            drift = diff - pe * pe - old * old
            if drift > 0.0 and drift > 6.0 * fresh * math.sqrt(diff / n):
                old = math.sqrt(old * old + drift)
        if not pe >= old:
            return None
        return pe, old

    def add_temperature(self, celsius):
        self.temp_sum += celsius
        self.temp_n += 1

    def quick(self):
        """True if this session ends in a quick re-calibration (so far)."""
        if self.kind == QUICK:
            return True
        return self.kind == AUTO and self.coverage() < self.cfg["min_coverage"]

    def attach(self, delag):
        """The Delag that de-lags this session's samples (survey.py): the tau estimate's steps."""
        if self._lagfit is not None:
            self._lagfit.attach(self, delag)

    def _solve(self, max_iter=60, final=False, independent=1.0):
        # provisional solves of an auto session are full ones: it becomes quick only at the end. A final
        # quick one drains the ring between its stages (self.service: the finish takes longer than the ring holds)
        quick = self.kind == QUICK or (final and self.quick())
        # finally the samples at the estimated tau (lagfit.py), in 1/u sum units
        fit, u = self._final if final and self._final is not None else (self.fit, 1)
        cal = fit.solve(field=None, prior=self.prior if quick else None, scale=[k / u for k in self.k],
                        max_iter=max_iter, refuse_worse=final, independent=independent, between=self.service if final else None)
        return cal if u == 1 else cal.scaled_input(1.0 / u)

    def tick(self, now_ms, diff):
        """Provisional solve every solve_every_s; returns True if one ran."""
        if self.fit.n < _MIN_PROVISIONAL:
            return False
        if diff(now_ms, self.last_solve) < self._solve_ms:
            return False
        self.last_solve = now_ms
        self.solves += 1
        g = self.gates
        try:
            cal = self._solve(_PROVISIONAL_ITER)
        except FitError:
            self.provisional_error = None
            return True
        d = cal.diagnostics
        pe = d.get("predicted_error")
        self.provisional_error = pe
        limit = disturbance_limit(self.cfg, d.get("rms", 0.0), pe or 0.0)
        # gate disturbances only with a fit good to a quarter of the gate
        g.use_provisional(cal if (pe is not None and pe < 0.25 * limit) else None, limit)
        return True

    def next_check_ms(self, now_ms, diff):
        """ms from now_ms until tick or timed_out may next act (<= 0: at once): tick's solve when
        the fit has samples enough for one, else its check on the next pass; the timeout."""
        solve = self._solve_ms - diff(now_ms, self.last_solve)
        timeout = self._max_ms + 1 - diff(now_ms, self.started)
        return solve if solve < timeout else timeout

    def coverage(self):
        return self.cov.fraction()

    def ready(self):
        pe = self.provisional_error
        need = self.cfg["quick_min_coverage"] if self.kind == QUICK else self.cfg["min_coverage"]
        return self.coverage() >= need and pe is not None and pe <= self.cfg["target_error_nt"]

    def progress(self, report=False):
        """The session's state; report: the once-a-second event, which also decides
        slow_down from the samples since the last one."""
        pe = self.provisional_error
        g = self.gates
        if report:
            seen = g.seen - self._seen_mark
            self.slow_down = seen > 0 and 2 * (g.rej_rate - self._fast_mark) > seen
            self._fast_mark = g.rej_rate
            self._seen_mark = g.seen
        return {
            "state": self.state,
            "kind": self.kind,
            "gate_dps": round(self.gate_dps, 1),
            "slow_down": self.slow_down,
            "n": self.fit.n,
            "seen": g.seen,
            "coverage": round(self.coverage(), 3),
            "pred_nt": None if pe is None else round(pe, 3),
            "rej_rate": g.rej_rate,
            "rej_dist": g.rej_dist,
            "rej_cap": g.rej_cap,
            "removed": g.removed,
            "clipped": self.clipped,
            "ready": self.ready(),
            "dir": g.last_direction(),
            "hold": self.hold,
            "gates": g.path,        # the gates' sample: "native" (gatesc.mpy) or "python"
        }

    def cancel(self):
        self.state = CANCELLED
        self.reason = codes.CANCELLED
        self.message = "cancelled by the operator"

    def finish(self):
        """Solve and check. Returns (cal in code units, None, None) or (None, reason, message)."""
        # Clipping first: the orientations where the ADC saturates are missing from the fit
        # and would be wrong in the survey, whatever the residual says.
        if self.clipped * CLIP_FRACTION > self.gates.seen + self.clipped:
            return self._fail(codes.CLIPPED, "%d samples hit the ADC's full scale%s: lower the PGA gain (gain_x/y/z)"
                              " or keep magnets and iron away; the sensor saturates there"
                              % (self.clipped, "" if self.clip_axis is None else " on " + "xyz"[self.clip_axis]))
        try:
            self._final = None if self._lagfit is None else self._lagfit.estimate(self)
            cal = self._solve(final=True)
            self._serve()
            d = cal.diagnostics
            if d.get("mode") == RESHAPED or (d.get("mode") == QUICK and d.get("gains", 1) > 1):
                # a quick one chose a bigger model by likelihood ratios, which correlated
                # residuals inflate: solved again with the samples counted as independent
                # (scaling the ratios down can only keep a smaller model, so the common-gain
                # result stands as it is)
                rho, pairs, _ = self.residual_rho(cal)
                if rho is not None and rho > 2.0 / math.sqrt(pairs):
                    rho = min(rho, _MAX_RHO)
                    cal = self._solve(final=True, independent=(1.0 - rho) / (1.0 + rho))
                    self._serve()
        except FitError as e:
            return self._fail_fast(e.reason, str(e))
        self._widen(cal)
        self._serve()
        problem = self.check(cal)
        if not problem and self._lagfit is not None:
            problem = self._lagfit.not_first_order(self.response, cal)
        if problem:
            return self._fail_fast(problem[0], problem[1] + self._response_left(cal))
        self.state = DONE
        code_cal = cal.scaled_input(1.0 / self.window)
        code_cal.diagnostics["coverage"] = round(self.coverage(), 4)
        code_cal.meta["kind"] = cal.diagnostics.get("mode", FULL)
        if self.response is not None:
            code_cal.response = check_response(self.response)   # fitted on samples de-lagged with it
        if self.temp_n:
            code_cal.meta["temperature_c"] = round(self.temp_sum / self.temp_n, 2)
        return code_cal, None, None

    def _serve(self):   # the ring drained between the finish's long steps (docs/firmware.md, "The finish")
        if self.service is not None:
            self.service()

    def _response_left(self, cal):
        """What residuals that follow each other say after de-lagging ("" when the samples were
        not de-lagged, or the residuals are independent): with the turn rate, the sensor's
        lag is not the configured one (too much de-lagged, or more than one pole: measured
        +0.70 for a bandwidth configured 20 % low, +0.56 for two poles, docs/firmware.md);
        without it, axes that lag differently (an error first order in the rate, whose sign
        follows the direction of the turn) or a field that moves."""
        d = cal.diagnostics
        rho = d.get("residual_rho")
        turn = d.get("residual_turn_corr")
        # a fast sensor's response is the ADC's and the boxcar's, known (shared/delag.py): its
        # residuals that follow each other say nothing of a lag
        if self.response is None or rho is None or rho <= 0.5 or not sensor_is_slow(self.cfg):
            return ""
        est = self.response.get("source") == "estimated"   # lagfit.py: a wrong bandwidth is ruled out
        why = "; de-lagged with tau %.1f ms (%s), the residuals still follow each other (rho %.2f" % (
            1e3 * self.response["tau_s"][0], "estimated" if est else "sensor_bandwidth_hz", rho)
        if turn is not None and abs(turn) > 0.3:
            return why + ", with the turn rate %.2f): the sensor's response is not that one (%s); fluxcal fit --lag " \
                "auto on a fluxcal capture estimates tau or says it is not first order" % (
                    turn, "more than one pole" if est else "a wrong bandwidth, or more than one pole")
        return why + "): axes that lag differently, or a field that moves; fluxcal fit --lag auto on a fluxcal " \
            "capture estimates per-axis taus"

    def _widen(self, cal):
        # the residuals' correlation over the whole session, from their batch means under this fit
        # (residuals.py), widens the core's predicted error (narrows it where their sums cancel, as a
        # de-lag term's differences do): shared.honest, which `fluxcal fit` and `report` call too
        d = cal.diagnostics
        rho, pairs, rate = self.residual_rho(cal)
        if rho is not None:
            d["residual_rho"] = round(rho, 4)
        if rate is not None:
            d["residual_turn_corr"] = round(rate, 3)
        pe = d.get("predicted_error")
        rms = d.get("rms")
        if pe is not None and rms is not None:
            import residual_stats
            from shared.honest import correlation_time, delag_share, honest_error, systematic_floor
            means, counts = residual_stats.batch_means(self.gates.batches, cal, self.tau_t)
            # the de-lag term's noise telescopes: the rest of the rms is what the fit feels
            k = 0.0 if self.response is None else self.response["tau_s"][0] * 1000.0 / (12.0 * self.period_ms)
            share = delag_share(rms, self.white, k)
            tau = correlation_time(means, counts, rms * math.sqrt(share))
            pinned = d.get("mode") in (QUICK, RESHAPED)   # the field kept from the one in force
            floor = systematic_floor(rms, self.white) if pinned and self.white is not None else 0.0
            d["tau_int"] = round(tau, 2)
            d["predicted_error_white"] = pe
            if share < 1.0:
                d["delag_share"] = round(share, 4)
            if tau * share != 1.0 or floor > pe:
                d["predicted_error"] = honest_error(pe, d.get("prior_error"), tau * share, floor)
                if floor:
                    d["systematic_floor"] = round(floor, 4)
        if self.response is not None and d.get("predicted_error") is not None:
            # de-lagged with a tau known to tau_sigma: a lag of that much may be left, reading |B|
            # short by B (sigma w)^2 / 2 (gates.py gate_dps). The fit takes its mean into the field;
            # what follows the squared turn rate from sample to sample is left: its sd over the
            # accepted pairs, (w T)^2 per period T, gives B sigma^2 sd(w^2) / 2, added in quadrature
            per = self.response["tau_sigma_s"][0] * 1000.0 / self.period_ms
            e = 0.5 * cal.field * per * per * self.turn_sd
            d["predicted_error_response"] = round(e, 4)
            d["predicted_error"] = math.sqrt(d["predicted_error"] ** 2 + e * e)
        elif d.get("predicted_error") is not None:
            # not de-lagged (delag or delag_adc off): the whole response's lag is left in the
            # samples (shared/delag.py response_tau_s), |B| short by B (tau w)^2 / 2 and leaning
            # along the motion. Counted as the tau term above it over-predicts 1.6-4.3 times (the
            # share the fit keeps follows how the pace goes with the orientation, which no sum
            # here measures), uncounted it under-predicts to 0.44 (docs/limits.md): where it is
            # the larger, the record says so (lag_left_nt; fluxcal pull-cal shows it)
            per = response_tau_s(self.cfg) * 1000.0 / self.period_ms
            e = 0.5 * cal.field * per * per * self.turn_sd
            if e > d["predicted_error"]:
                d["lag_left_nt"] = round(e, 4)

    def _fail_fast(self, reason, message):
        # most samples of a couple of seconds or more turned faster than the gate: that,
        # not the coverage, is the reason (a session finished at once says too_few_samples)
        g = self.gates
        if g.seen >= 2 * g.back and g.rej_rate * 2 > g.seen and reason != codes.NOT_BETTER:
            return self._fail(codes.TOO_FAST, "%d of %d samples turned faster than %.0f deg/s (%s): turn slower"
                              % (g.rej_rate, g.seen, self.gate_dps, message))
        return self._fail(reason, message)

    def _fail(self, reason, message):
        self.state = FAILED
        self.reason = reason
        self.message = message
        return None, reason, message

    def check(self, cal):
        """Acceptance thresholds (acceptance.py); (reason, message) for the first that fails, else None."""
        return check_calibration(cal, self.cfg, self.k)
