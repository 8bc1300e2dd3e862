"""The survey output: what every decimated sample becomes (|h_c|, block averages at survey_hz,
the data/raw events, the lines of the rotating flash log: flashlog.py).

    out = Output(board, proto)       # app.py wires it
    out.configure(cfg, sample_hz)    # the spike screen, the survey averager, the log (config.py)
    out.use(cal)                     # the calibration in force (None: uncalibrated)
    out.sample(rx, ry, rz, rt)       # acq.poll's on_sample: screen -> session -> |h_c| -> survey
    out.gap(missing)                 # acq.poll's on_gap
    out.status()                     # its part of `status`

    sv = Survey(cfg, window, decim_rate_hz); rec = sv.sample(sx, sy, sz, st, f)   # None, or a block

A sample's way (the DRDY ring's reader calls Output.sample directly): the screen (screen.py)
drops spikes and clipped samples; a slow sensor's lag is undone (shared/delag.py, two samples
later: after the screen, which a de-lagged spike spread over three samples would pass); a
calibration in progress (`session`, set by calibration_flow.py) gets the good ones; |h_c| per
sample, only when a block goes out (stream or log), is averaged over the block with the raw
sums. A finished block gets the die temperature (one per block: it changes over seconds), is
corrected, and goes out as a `data` or `raw` event and a log line.

A block over 1/survey_hz (0.1 s at the default 10 Hz, the paper's moving average width, IV.C)
averages |h_c| of every decimated sample -- rotation invariant -- and, separately, the raw
vector (integer sums). Averaging the vectors and taking |.| afterwards would shrink |B| by ~B
(w T)^2/24 while the operator turns: 769 nT at 1 rev/s over 0.1 s (docs/simulator.md, smearing).

Temperature compensation (docs/temperature.md): the calibration in force at the die temperature
(_compensate; how far its coefficients hold: the constants below), a warning beyond (_temperature_warning).
"""

import json
from array import array
from struct import unpack_from

from flashlog import RotatingLog
from protocol import DATA_LINE, RAW_LINE, VERSION, hundredths, json_number, parts3
from screen import Screen
from shared.delag import DELAY, Delag, configured_tau_s, tau_us
from shared.fixedpoint import FRACTION_BITS, ExactCorrection

# In C where deploy installed the board's .mpy (MicroPython; ValueError: one of another arch or
# version): a sample's |h_c| and the block's sums (fitsums.survey, device/native/hc.h), a block's
# event line (fitsums.line, line.h), and Output.sample itself (drdy.Sample, device/native/drdy.c:
# the same calls, no Python frame)
try:
    from fitsums import line as _native_line, survey as _native_survey
except (ImportError, ValueError):
    _native_line = _native_survey = None
try:
    from drdy import Sample as _NativeSample
except (ImportError, ValueError):
    _NativeSample = None
# fitsums.survey's words (an array("H"), hc.h): five 64-bit sums (x, y, z, t, |h_c|) of four
# limbs each, the samples the block still takes, 1 if |h_c| is summed (else 0), its numbers
_LEFT, _HAS_F, _NUMBERS_AT = 20, 21, 22
# re-apply the temperature coefficients when the die moved this much: at 20 ppm/C and
# 1 nT/C a step of 0.05 nT at 48,000 nT, below the noise
_TEMP_STEP_C = 0.05
# the coefficients hold a little beyond the temperatures they were measured at (each a
# calibration's mean die reading): warn only this far outside their range
_RANGE_MARGIN_C = 1.0
_EXTRAPOLATE_C = 10.0     # and are applied at most this far outside it (held there beyond)
# the log line, one bytes format (as protocol.py's event lines: a str made costs ~15 k cycles on an RP2040)
_LOG = b"%d,%s%d.%03d,%s%d.%03d,%s%d.%03d,%d.%03d,%.2f\n"
_LINE_BYTES = 320     # fitsums.line's buffer: a data event ~190 bytes, ~290 with the longest warning


class Survey:
    """The output blocks' sums: in C (fitsums.survey, Output.sample calls it) in `words` where it
    loads (native=True), counting down words[_LEFT]; sample() is the pure-Python way (the reference,
    and the C's fall-back for a sample past its words: its sums here); finish() adds the two."""

    def __init__(self, cfg, window, sample_hz, native=True):
        self.window = window
        self.per_block = max(1, int(sample_hz / cfg["survey_hz"] + 0.5))
        self.blocks = 0
        # blocks under 2**16 samples: the C's 64-bit sums cannot overflow, LEFT is a limb (hc.h)
        self.words = array("H", [0] * (_NUMBERS_AT + 64)) if native and _native_survey and self.per_block < 1 << 16 else None
        self._zeros = array("H", bytes(2 * _LEFT))     # restart's: one slice store, not 20 (~10 k cycles)
        self.restart()

    def restart(self):
        """Drop the open block (its samples were taken without |h_c|)."""
        self._n = 0
        self._sx = self._sy = self._sz = self._st = self._f = 0
        w = self.words
        if w is not None:
            w[:_LEFT] = self._zeros
            w[_LEFT] = self.per_block

    def sample(self, sx, sy, sz, st, f):
        """Accumulate; at the end of a block return its sums (x, y, z, t codes; f) and n."""
        self._sx += sx
        self._sy += sy
        self._sz += sz
        self._st += st
        self._f += f
        w = self.words
        if w is None:
            self._n += 1
            return self.finish() if self._n >= self.per_block else None
        w[_LEFT] -= 1
        return None if w[_LEFT] else self.finish()

    def finish(self):
        """The full block's sums (x, y, z, t codes; f) and n, the next block opened."""
        w = self.words
        # the C's five 64-bit two's complements, low limb first (little-endian, as the boards and
        # hc.h have them): one unpacking in C, small ints where they fit (x, y, z, t), instead of
        # the limbs read and joined in bytecode (~36 k cycles a block on an RP2040, ~18 k so)
        s = (0, 0, 0, 0, 0) if w is None else unpack_from("<5q", w)
        s = (s[0] + self._sx, s[1] + self._sy, s[2] + self._sz, s[3] + self._st, s[4] + self._f, self.per_block)
        self.blocks += 1
        self.restart()
        return s


class Output:
    def __init__(self, board, proto, native=True):
        self.board = board
        self.proto = proto
        self.adc = None            # the ADS1292Pair: the die temperature's conversion (app.py)
        self.acq = None            # the Acquisition: the block numbers (app.py; the raw event's n)
        self.session = None        # the calibration in progress, fed every good sample
        self.cfg = None
        self.stream = "off"        # "off", "raw" or "corrected" (the stream command, config)
        self.log = None
        self.recorder = None       # a survey being recorded (surveylog.Recorder): each block's |B|
        self.survey = None
        self.screen = None
        self._chain = None         # what the screen and the de-lag were made for (configure)
        self.delag = None          # the sensor's lag undone (shared/delag.py), when _delag_on
        self._delag_on = False
        self.scale = None
        self.cal = None            # the calibration in force
        self.cal_now = None        # the calibration at the die temperature (tempco applied)
        self.exact_w = None        # cal_now in integers for sums of `window` codes (per sample)
        self.exact_blk = None      # and for a block's sums (per block)
        self._words = None         # the survey's words where fitsums.survey takes the samples
        self._clipped = 0          # the screen's clipped count at its last dropped sample
        self.temp_c = None
        self.cal_temp_warn = False
        self._comp_temp = None
        self._want_f = False
        self._line = None    # fitsums.line's buffer (a memoryview) while blocks go out
        # sample in C (native=False: the class's, the reference): an instance attribute, found
        # before the method (app.py binds it once; acq.poll's C calls it without a frame)
        if native and _NativeSample is not None:
            self.sample = _NativeSample(self, _native_survey)

    def configure(self, cfg, sample_hz):
        c = self.cfg = cfg
        self.survey = Survey(c, c["window"], sample_hz)
        self.scale = (c["scale_x"], c["scale_y"], c["scale_z"])
        # the screen and the de-lag kept (what they hold and learnt) where none of theirs changed, as
        # at `config set survey_hz`: a new screen knows no hand's bends, a reversal may look a spike
        chain = (self.scale, c["window"], c["spike_nt"], c["rate"], c["decim"], c["gain_x"], c["gain_y"],
                 c["gain_z"])
        if chain != self._chain:
            self._chain = chain
            self.screen = Screen(self.scale, c["window"], c["spike_nt"])
            self._clipped = 0
            self.delag = Delag(c["window"])
            # the gates' break_chain reached through this Output, never bound: held by the de-lag,
            # the gates' bound method kept an ended session's gates, fit and their modules'
            # bytecode alive into the next (a second calibration: 256 KB of a 32-bit heap, 210 without)
            self.delag.on_hole = self._hole
        self._f_unit = 1000.0 * (1 << FRACTION_BITS) / c["window"]   # nT of a window's sums -> |h_c|'s unit
        if c["log"] and self.log is None:
            self.log = RotatingLog(self.board.root, c["log_file_bytes"], c["log_files"], c["log_reserve_bytes"])
        elif not c["log"] and self.log is not None:
            self.log.close()
            self.log = None
        self._outputs()

    def use(self, cal):
        """Make cal (or None) the calibration the output applies (from the next sample)."""
        self.cal = cal
        if self.survey is not None:   # configured: else configure() applies it
            self._outputs()

    def set_stream(self, mode):
        self.stream = mode
        self._outputs()

    def close(self):
        if self.log is not None:
            self.log.close()

    def _outputs(self):
        # |h_c| per sample is only needed when a block goes out (stream, log or recording)
        want = self.stream != "off" or self.log is not None or self.recorder is not None
        if want and not self._want_f:
            self.survey.restart()   # the open block's samples carry no |h_c|: start a new one
        self._want_f = want
        # fitsums.line's buffer while blocks go out, its 336 bytes back to the heap after (a finish wants them)
        self._line = None if not want or _native_line is None else self._line or memoryview(bytearray(_LINE_BYTES))
        self._compensate(self.temp_c, True)
        self.respond()

    def respond(self):
        """De-lag with the response of what the samples feed: a calibration in progress's (the
        configured one, session.py); none for the raw stream (the codes as read, which fluxcal
        capture records and fluxcal fit --lag de-lags itself); else the one the calibration in
        force was fitted with (none if its record has none: its samples were not de-lagged),
        else the configured one. Called again when a session starts or ends and when the stream changes."""
        c = self.cfg
        s = self.session
        if s is not None:
            taus = s.taus_us
        elif self.stream == "raw":
            taus = None
        elif self.cal is not None:
            r = self.cal.response
            taus = None if r is None else [tau_us(t) for t in r["tau_s"]]
        else:
            tau = configured_tau_s(c, self.board.polls_drdy)
            taus = None if tau is None else [tau_us(tau)] * 3
        self.delag.set_taus(taus, c["rate"], c["decim"], None if s is None else s.steps_us)
        self._delag_on = self.delag.taus_us is not None
        if s is not None:
            s.attach(self.delag)   # its tau estimate reads the steps (shared/tausums.py)

    def _compensate(self, temp, force=False):
        """The calibration at the die temperature (its tempco applied; docs/temperature.md),
        recomputed when the temperature moved by _TEMP_STEP_C: about 40 float operations."""
        cal = self.cal
        tau = None
        if cal is not None and cal.tempco is not None and temp is not None:
            # linear beyond the measured range for a few degrees, held there after: a die
            # reading far off (a fault, a hot spot) must not extrapolate the drift without end
            lo, hi = cal.tempco["range_c"]
            temp = min(max(temp, lo - _EXTRAPOLATE_C), hi + _EXTRAPOLATE_C)
            if not force and self._comp_temp is not None and abs(temp - self._comp_temp) < _TEMP_STEP_C:
                return
            self._comp_temp = temp
            tau = temp - cal.tempco["t0_c"]
            cal = cal.at_temperature(temp)
        elif not force:
            return
        self.cal_now = cal
        # the correction in integers (shared/fixedpoint.py): the same digits on every float width
        w = self.cfg["window"]
        self.exact_w = ExactCorrection(self.cal, w, tau) if cal is not None else None
        self.exact_blk = ExactCorrection(self.cal, w * self.survey.per_block, tau) if cal is not None else None
        # the per-sample |h_c| and block sums in C where they load, and |h_c| is either not
        # wanted (0) or exact_w's in C; else (the float |h_c| uncalibrated) in Python
        ex = self.exact_w
        numbers = ex._native if self._want_f and ex is not None else None
        w = self._words = self.survey.words if numbers is not None or not self._want_f else None
        if w is not None:       # |h_c| summed in C with exact_w's limbs, or 0
            w[_HAS_F] = 0 if numbers is None else 1
            for i in range(64 if numbers is not None else 0):
                w[_NUMBERS_AT + i] = numbers[i]

    # ****** per sample: the DRDY ring's reader calls these ******
    def gap(self, missing=0):
        # one sample lost (a polled DRDY's usual gap) while de-lagging: the screen judges across
        # it and the de-lag fills it (screen.py bridge, shared/delag.py join), else both restart
        s = self.session
        dl = self.delag
        if missing == 1 and self._delag_on and dl.can_join() and self.screen.bridge(dl.join):
            return
        self.screen.reset()
        dl.reset()
        if s is not None:
            s.break_chain()

    def _hole(self):
        """The de-lag's on_hole: the sample after a bridged hole has no neighbour for the gates."""
        if self.session is not None:
            self.session.break_chain()

    def sample(self, rx, ry, rz, rt):
        # the reference of drdy.Sample, which runs instead where it loads. A frame of at most 11 slots
        # (arguments as locals, the value stack): more is a heap allocation a call (py/objfun.c)
        if not self.screen.push(rx, ry, rz, rt):
            return self._dropped()
        ry = self.screen
        if self._delag_on:
            rz = self.delag
            if not rz.push(ry.x, ry.y, ry.z, ry.t):
                return
            ry = rz
        rz = self.session
        if rz is not None:
            rz.sample(ry.x, ry.y, ry.z)
        # |h_c| in 1/256 milli-nT summed with the block's sums in C: no int made (a big int on the Pico)
        rx = self._words
        rz = None if rx is None else _native_survey(rx, ry.x, ry.y, ry.z, ry.t)
        if rz is None:         # no fitsums.survey, the float |h_c|, or past its words: in Python
            return self._survey(ry.x, ry.y, ry.z, ry.t)
        return self._output(self.survey.finish()) if rz else None

    def _dropped(self):
        """The screen dropped the sample: a clipped one counts in the session's `clipped`."""
        sc = self.screen
        if sc.clipped != self._clipped:
            self._clipped = sc.clipped
            if self.session is not None:
                self.session.clipped += 1
                self.session.clip_axis = sc.clip_axis

    def _survey(self, sx, sy, sz, st):
        # |h_c| per decimated sample in 1/256 milli-nT, averaged over the block (rotation invariant)
        f = 0
        if self._want_f:
            ex = self.exact_w
            if ex is not None:
                f = ex.magnitude(sx, sy, sz)
            else:
                k = self.scale
                f = int(((sx * k[0]) ** 2 + (sy * k[1]) ** 2 + (sz * k[2]) ** 2) ** 0.5 * self._f_unit)
        blk = self.survey.sample(sx, sy, sz, st, f)
        if blk is not None:
            self._output(blk)

    def _output(self, blk):
        sx, sy, sz, st, fs, n = blk
        d = n * self.cfg["window"]
        temp = self.adc.temperature_c(st / d)
        self.temp_c = temp
        if self.session is not None:
            self.session.add_temperature(temp)   # one per block: the die changes over seconds
        if self.cal is not None and self.cal.tempco is not None:
            self._compensate(temp)      # else nothing to do: no call (~7 k cycles a block)
        cal = self.cal_now
        msg = self._temperature_warning(temp)
        if not self._want_f:
            return   # nothing goes out: no stream, no log
        t = self.board.ticks_ms()
        stream = self.stream
        if stream != "off":
            tv = b"null" if temp != temp else b"%.2f" % temp     # not a number (a fault): null
            # the block's mean codes in hundredths from the integer sums: no float to box and print
            c0, c1, c2 = hundredths(sx, d), hundredths(sy, d), hundredths(sz, d)
        if stream == "raw":
            # n: its last sample's block number (the screen holds one back, the de-lag DELAY more)
            seq = -1 if self.acq is None else (self.acq.last_block - 1 - (DELAY if self._delag_on else 0)) & 0x3FFFFFFF
            line = self._fill(RAW_LINE, (VERSION, t, seq, c0, c1, c2, tv))
            self.proto.send_line(line or RAW_LINE % ((VERSION, t, seq) + parts3(c0, c1, c2, 100) + (tv,)))
            if self.recorder is None and (self.log is None or self.session is not None):
                return
        # h_c and |h_c| in milli-nT, integers: printed to the last digit a narrow float cannot hold
        ex = self.exact_blk
        if ex is not None and ex.divisor != d:
            ex = self.exact_blk = ExactCorrection(self.cal, d, ex.tau)
        if ex is not None:
            b = ex.correct(sx, sy, sz)
        else:
            k = self.scale
            b = (round(sx / d * k[0] * 1000), round(sy / d * k[1] * 1000), round(sz / d * k[2] * 1000))
        # the mean |h_c| in milli-nT, rounded (halves up): fs is a big int on a 32-bit port, one
        # heap allocation an operation, so the fewest (not (2 fs + 2^8 n) // (2^9 n))
        f = (fs + (n << (FRACTION_BITS - 1))) // (n << FRACTION_BITS)
        if stream == "corrected":
            cal = b"false" if cal is None else b"true"
            msg = b"null" if msg is None else json.dumps(msg).encode()
            line = self._fill(DATA_LINE, (VERSION, t, tv, c0, c1, c2, cal, msg, b[0], b[1], b[2], f))
            self.proto.send_line(line or DATA_LINE % ((VERSION, t, tv) + parts3(c0, c1, c2, 100) + (cal, msg) +
                                                      parts3(b[0], b[1], b[2], 1000) + divmod(f, 1000)))
        if self.recorder is not None:
            self.recorder.block(t, f)
        if self.log is not None and self.session is None:
            self.log.write(_LOG % ((t,) + parts3(b[0], b[1], b[2], 1000) + divmod(f, 1000) + (temp,)))

    def _fill(self, fmt, values):
        """fitsums.line's line in the buffer (a view: nothing else allocated), or None: Python's `%`."""
        n = None if self._line is None else _native_line(self._line, fmt, values)
        return None if n is None else self._line[:n]

    def _temperature_warning(self, temp):
        """Whether the die's temperature makes the calibration in force doubtful (cal_temp_warn)
        and the warning's text, or None."""
        cal = self.cal_now
        msg = None
        if cal is not None and self.cal.tempco is not None:
            # compensated: a warning only outside the range the coefficients were measured over
            lo, hi = self.cal.tempco["range_c"]
            if temp < lo - _RANGE_MARGIN_C or temp > hi + _RANGE_MARGIN_C:
                msg = "temperature %.1f C outside the compensated %.1f..%.1f C" % (temp, lo, hi)
        elif cal is not None:
            tcal = cal.meta.get("temperature_c")
            if tcal is not None and abs(temp - tcal) > self.cfg["temp_warn_c"]:
                msg = "temperature %.1f C differs from calibration %.1f C" % (temp, tcal)
        self.cal_temp_warn = msg is not None
        return msg

    def status(self):
        """Its part of `status`: the stream, the die temperature, the screen's counts, the log."""
        out = {"stream": self.stream, "temp": json_number(self.temp_c, 2), "temp_warn": self.cal_temp_warn,
               "spikes": self.screen.spikes, "clipped": self.screen.clipped,
               # the spike screen's push and this sample: "native" (screenc.mpy; drdy.Sample) or "python"
               "screen": self.screen.path, "sample": "native" if type(self.sample) is _NativeSample else "python",
               # the taus (us per axis) the samples are de-lagged with, None: not de-lagged
               "delag_us": self.delag.taus_us if self._delag_on else None, "delag": self.delag.path,
               # |h_c| of the calibration in force: "native" (fitsums.mpy) or "python"; None: none
               "magnitude": None if self.exact_w is None else self.exact_w.path}
        if self.log is not None:
            out["log"] = {"lines": self.log.lines, "error": self.log.error}
        return out
