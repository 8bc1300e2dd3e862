"""TI ADS1292 emulator: one chip on its SPI bus, byte by byte.

Facts and section numbers come from ../shared/reference/ads1292-and-runtimes.md
([DS] = TI datasheet SBAS502C). The interface is documented for the firmware in
docs/simulator.md ("ADS1292 emulator").

Usage (byte level, as the firmware's simulation HAL drives it)::

    chip = ADS1292(seed=1)
    chip.load(volts, rate_hz=16000)          # (n, 2) analog inputs, V
    chip.advance(0.05)                       # > tPOR
    chip.select(True); chip.transfer(b"\\x11"); chip.select(False)   # SDATAC
    ...
    chip.start = True                        # START pin
    chip.wait_drdy(); chip.select(True); frame = chip.transfer(bytes(9))

The codes come from convert.py (the vectorised path, the same arithmetic), so
a capture and a byte-level run of the same grid agree code for code.
Time is counted in modulator ticks tMOD = 1 / 128 kHz (internal 512 kHz
oscillator, CLK_DIV=0, fMOD = fCLK / 4 [DS §8.3.7]); every event (START, DRDY,
byte transfers) lands on an integer tick, so the byte path and the vectorised
path agree exactly on which analog samples each conversion sees.
"""

import math
from fractions import Fraction

import numpy as np

from desktop.sim.ads1292.convert import NO_NOISE, convert
from desktop.sim.ads1292.registers import (CONFIG1, CH1SET, CH2SET, Config, DECODE_TICKS,
                                           F_MOD, FIXED, FRAME_BYTES, GPIO, ID, LOFF_STAT, N_REGISTERS,
                                           OFFSETCAL, RDATA, RDATAC, RESET, RESET_BUSY_TICKS, RESET_VALUES,
                                           RREG, SDATAC, SETTLE_TICKS, STANDBY, START, STOP, T_POR_TICKS,
                                           WAKE_TICKS, WAKEUP, WREG, WRITABLE, frame_bytes, status_word)

# Fault injection (docs/simulator.md): a chip that does not answer, a stuck DRDY,
# corrupted status words or bits, an input beyond full scale, an oscillator off frequency.
# Given at construction or switched at run time (ADS1292.set_fault).
FAULTS = ("absent-0x00", "absent-0xff", "drdy-stuck-high", "drdy-stuck-low",
          "status-corrupt", "bit-flips", "clipping", "clock-drift")
# `rate` of a fault when none is given: probability per frame (status-corrupt), per bit
# (bit-flips); the oscillator's relative frequency error (clock-drift)
DEFAULT_FAULT_RATES = {"status-corrupt": 0.01, "bit-flips": 1e-4, "clock-drift": 0.005}
_DRDY_DEAD = ("absent-0x00", "absent-0xff", "drdy-stuck-high", "drdy-stuck-low")


class ADS1292:
    """One ADS1292 on an SPI bus (mode 1), emulated byte by byte.

    Parameters
    ----------
    chip_id : int
        Value of the ID register (0x53 ADS1292, 0x52 ADS1291, 0x73 ADS1292R).
    seed : int or numpy.random.Generator or None
        Seeds the ADC noise (and fault draws, from a separate stream).
    noise : bool
        False: no input-referred noise (an ideal converter, for tests).
    fault : str or None
        One of FAULTS (see docs/simulator.md); :meth:`set_fault` switches it later.
    fault_rate : float
        Probability per frame ("status-corrupt") or per bit ("bit-flips"); the
        oscillator's relative frequency error ("clock-drift", e.g. -0.005).
    sclk_hz : float
        SPI clock: each transferred byte takes 8 / sclk_hz of chip time.
    strict : bool
        Ignore commands that break the datasheet's timing rules (they are
        always recorded in `violations`).
    batch : int
        Conversions computed per vectorised :func:`convert` call (see
        :attr:`batch`); 1 computes each when its DRDY comes due. Any value
        gives the same codes, DRDY ticks, frames, faults and violations.
    vref_tempco : float
        The internal reference's drift, relative per C about 25 C (within
        +-45e-6 [DS §6.5]; see :func:`convert`); 0 (default): none.
    """

    def __init__(self, chip_id=0x53, *, seed=None, fault=None, fault_rate=None,
                 sclk_hz=1_000_000, strict=True, noise=True, batch=1, vref_tempco=0.0):
        self.chip_id = chip_id
        self.vref_tempco = float(vref_tempco)
        self.fault, self.fault_rate = None, 0.01
        # the oscillator: own modulator ticks per nominal tick = _num / _den (clock-drift)
        self._num = self._den = 1
        self._anchor = 0               # nominal tick from which the conversion schedule counts
        self._m_next = None            # own ticks from _anchor to the next DRDY
        self._next_drdy = None         # nominal tick of the next DRDY (None: none scheduled)
        self._cfg_regs, self._cfg = None, None   # Config of the register map, decoded once
        self.set_fault(fault, fault_rate)
        self.rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        # faults draw from a child stream so they never shift the noise sequence
        self._fault_rng = np.random.default_rng(self.rng.bit_generator.seed_seq.spawn(1)[0])
        self.noise = noise
        self.sclk_hz = float(sclk_hz)
        self.strict = strict
        self.violations = []
        self.temperature_c = 25.0      # die temperature when no source is loaded
        self._volts = np.zeros((1, 2))
        self._temp = None
        self._step, self._grid_tick0 = 8, 0
        self._ticks_f = 0.0            # chip time in ticks (float accumulator)
        self.tick = 0                  # chip time, integer modulator ticks
        self._busy_until = T_POR_TICKS
        self._start_pin = False
        self._selected = False
        self._power_down = False
        self.conversions = 0           # conversions completed since power-up
        self.drdy_falls = 0            # DRDY falling edges since power-up
        self._drdy_low = False
        self.start_tick = None         # tick of the last START (pin or command)
        self._cache = None             # batched codes, see _codes
        self._normals = np.zeros((0, 2))   # noise normals drawn ahead of use, see _take_normals
        self._normals_off = 0          # of which this many rows are consumed already
        self._normals_rng = self.rng
        self._normals_used = 0         # rows of normals consumed since power-up
        self.batch = batch
        self._power_on_reset()

    # ----------------------------------------------------------------- state
    def _power_on_reset(self):
        self.registers = list(RESET_VALUES)
        self.registers[ID] = self.chip_id
        self.rdatac = True             # wakes up in RDATAC mode [DS §8.3.11]
        self.standby = False
        self._running = False          # START command or pin
        self._start_cmd = False
        self._m_next = self._next_drdy = None
        self._stop_after_next = False
        self._set_frame(status_word(0, self._gpio_bits()), (0, 0))
        self._out_ptr = 0
        self._cmd = []                 # bytes of a multi-byte command in progress
        self._pending_out = b""       # RREG / RDATA output queued for next bytes
        self._wreg_left = 0
        self._swallow = 0

    def _gpio_bits(self):
        return self.registers[GPIO] & 0x03 if hasattr(self, "registers") else 0

    @property
    def config(self):
        """The current register map decoded (:class:`Config`); decoded again only after a change."""
        regs = tuple(self.registers)
        if regs != self._cfg_regs:
            self._cfg_regs, self._cfg = regs, Config(regs)
        return self._cfg

    # ----------------------------------------------------------------- faults
    def set_fault(self, fault, rate=None):
        """Inject `fault` (one of FAULTS; None clears it) from the current chip time on.

        `rate`: probability per frame ("status-corrupt", default 0.01) or per
        bit ("bit-flips", 1e-4), or the oscillator's relative frequency error
        ("clock-drift", default +0.005: the chip runs 0.5 % fast; -0.005 slow).
        Nothing computed before the switch is served after it (the batch cache
        is dropped; a frame already converted keeps its data, as a real one
        would). A dead DRDY ("absent-*", "drdy-stuck-*") gives no falling edges
        while it lasts; the chip keeps its registers and mode, so once the fault
        is cleared a re-probe (SDATAC, RREG, WREG, RDATAC, START) works again.
        A new clock takes effect after the conversion in progress: the pending
        DRDY keeps its tick, the ones after it follow the new clock.
        """
        if fault is not None and fault not in FAULTS:
            raise ValueError("unknown fault %r (one of %s)" % (fault, ", ".join(FAULTS)))
        rate = DEFAULT_FAULT_RATES.get(fault, 0.01) if rate is None else float(rate)
        if fault == "clock-drift":
            if not -0.5 < rate < 0.5:
                raise ValueError("clock-drift rate is a relative frequency error in (-0.5, 0.5), got %r" % rate)
        elif not 0.0 <= rate <= 1.0:
            raise ValueError("fault rate is a probability in [0, 1], got %r" % rate)
        self.fault, self.fault_rate = fault, rate
        ratio = Fraction(1.0 + rate).limit_denominator(1_000_000) if fault == "clock-drift" else Fraction(1)
        if (ratio.numerator, ratio.denominator) != (self._num, self._den):
            if self._m_next is not None:        # re-anchor at the pending DRDY, which stays put
                self._anchor, self._m_next = self._next_drdy, 0
            self._num, self._den = ratio.numerator, ratio.denominator
        self._cache = None

    @property
    def clock_ratio(self):
        """The oscillator's frequency over the nominal 512 kHz (1 + the clock-drift rate)."""
        return self._num / self._den

    def _nominal_tick(self, m):
        """Nominal tick of own tick `m` counted from the schedule's anchor (the first
        nominal tick at or after it: events land on whole ticks)."""
        if self._num == self._den:
            return self._anchor + m
        return self._anchor - ((-m * self._den) // self._num)

    @property
    def time(self):
        """Chip time since power-up, s."""
        return self.tick / F_MOD

    @property
    def batch(self):
        """Conversions computed ahead per vectorised :func:`convert` call (int >= 1).

        One `convert` call costs ~0.5 ms whatever its length, so computing each
        conversion when its DRDY comes due limits the byte path to ~2000
        frames/s. With `batch` > 1, when a conversion comes due the chip
        computes it and up to `batch` - 1 of its successors (no further than
        the loaded grid reaches) and serves them from a cache while the
        register map, the analog input (:meth:`load`, `temperature_c`),
        `noise`, `fault` and the conversion schedule stay the same; anything
        else recomputes. The noise normals are drawn from `rng` ahead of use
        and consumed in conversion order, so the codes, DRDY ticks, frames,
        faults and violations equal those of `batch` = 1 exactly; only
        `rng`'s state runs ahead (do not share the Generator with anything
        else). Settable at any time; single-shot conversions are never
        batched. The loaded `volts` must not be changed in place (call
        :meth:`load` again).
        """
        return self._batch

    @batch.setter
    def batch(self, n):
        if int(n) != n or n < 1:
            raise ValueError("batch must be an integer >= 1, got %r" % (n,))
        self._batch = int(n)
        self._cache = None

    # ----------------------------------------------------------- analog input
    def load(self, volts, rate_hz=16000, t0=0.0, temperature_c=None):
        """Feed the analog inputs over time.

        Parameters
        ----------
        volts : (G, 2) array, V
            Differential inputs of CH1 and CH2 on a uniform grid.
        rate_hz : int
            Grid rate; must be fMOD / step with step in 1, 2, 4, 8, 16
            (128k, 64k, 32k, 16k, 8k) so every data rate sees whole samples.
        t0 : float
            Chip time (s) of the first sample; before / after the grid the
            first / last sample is held.
        temperature_c : (G,) array or float or None
            Die temperature (C) seen by MUX=0100.
        """
        step = F_MOD // int(rate_hz)
        if step * int(rate_hz) != F_MOD or 16 % step:
            raise ValueError("rate_hz must be 128 kHz / (1, 2, 4, 8 or 16), got %r" % rate_hz)
        volts = np.asarray(volts, dtype=float)
        if volts.ndim != 2 or volts.shape[1] != 2 or volts.shape[0] == 0:
            raise ValueError("volts must be a non-empty (G, 2) array")
        self._volts, self._step = volts, step
        self._grid_tick0 = int(round(t0 * F_MOD))
        self._cache = None
        if temperature_c is not None and np.ndim(temperature_c) == 0:
            self.temperature_c, self._temp = float(temperature_c), None
        else:
            self._temp = None if temperature_c is None else np.asarray(temperature_c, float)

    # ------------------------------------------------------------------ time
    def advance(self, seconds):
        """Let `seconds` of chip time pass; conversions complete on schedule."""
        if seconds < 0:
            raise ValueError("time runs forward")
        self._ticks_f += seconds * F_MOD
        self._run_until(int(self._ticks_f + 1e-6))

    def deadline_tick(self, timeout):
        """Modulator tick at which a wait of `timeout` s from now gives up.

        Time moves in whole ticks, so the deadline is rounded up to the next
        tick boundary, and a positive timeout always reaches at least the next
        tick (a wait shorter than tMOD = 7.8 us still lets time pass, so a
        caller retrying on TimeoutError cannot loop without progress).
        `timeout` = 0 is a poll: the deadline is now.
        """
        if not timeout >= 0:
            raise ValueError("timeout must be >= 0 s, got %r" % (timeout,))
        if timeout == 0:
            return self.tick
        end = math.ceil(self._ticks_f + timeout * F_MOD - 1e-6)
        return max(end, self.tick + 1)

    def next_drdy_tick(self, timeout=1.0):
        """Tick of the next DRDY falling edge if it comes by
        :meth:`deadline_tick` (`timeout`); otherwise advance to that deadline
        and raise TimeoutError (not started, standby, chip absent, DRDY stuck,
        or the next DRDY is later)."""
        deadline = self.deadline_tick(timeout)
        if self.fault in _DRDY_DEAD or self._next_drdy is None or self.standby \
                or self._next_drdy > deadline:
            self.advance_to_tick(deadline)
            raise TimeoutError("no DRDY within %.6f s" % timeout)
        return self._next_drdy

    def advance_to_tick(self, tick):
        """Let time pass up to modulator tick `tick` (no-op if already there)."""
        if tick > self._ticks_f:
            self._ticks_f = float(tick)
        self._run_until(max(tick, self.tick))

    def wait_drdy(self, timeout=1.0):
        """Advance to the next DRDY falling edge; return the seconds waited.

        Raises TimeoutError, with chip time at :meth:`deadline_tick`, if no
        conversion completes within `timeout` s (rounded up to whole modulator
        ticks; any positive timeout lets at least one tick pass, 0 polls
        without advancing). On a bus use :meth:`SPIBus.wait_drdy`, which moves
        every chip's clock.
        """
        start = self.tick
        self.advance_to_tick(self.next_drdy_tick(timeout))
        return (self.tick - start) / F_MOD

    def _run_until(self, target):
        while self._next_drdy is not None and self._next_drdy <= target and not self.standby:
            cfg = self.config
            d = cfg.decimation
            single = cfg.single_shot or self._stop_after_next
            if single:
                n = 1
            elif self._num == self._den:
                n = (target - self._next_drdy) // d + 1
            else:   # own ticks by `target`: conversions whose nominal tick is <= target
                n = (((target - self._anchor) * self._num) // self._den - self._m_next) // d + 1
            last = self._last_codes(cfg, n, single)
            m_last = self._m_next + (n - 1) * d
            self.tick = self._nominal_tick(m_last)
            self.conversions += n
            self._new_frame(last)
            if self.fault not in _DRDY_DEAD:
                self.drdy_falls += n           # a dead DRDY pin makes no edges
            if single:
                self._m_next = self._next_drdy = None   # single shot: DRDY stays low [DS §8.5.1.10]
                self._running = self._start_cmd = False
                self._stop_after_next = False
            else:
                self._m_next = m_last + d
                self._next_drdy = self._nominal_tick(self._m_next)
        if target > self.tick:
            self.tick = target

    def _last_codes(self, cfg, n, single):
        """The codes [CH1, CH2] of the last of the next n conversions (own ticks _m_next +
        i * decimation, i < n); the n conversions' noise rows are consumed.

        Served from the batch cache when it holds them, was computed for the
        same inputs, clock and schedule and its noise rows are the next unused
        ones; else computed with up to `batch` conversions ahead (see :attr:`batch`).
        """
        d = cfg.decimation
        m0 = self._m_next
        # everything convert() reads besides the tick and the noise rows
        key = (self._cfg_regs, self._step, self._grid_tick0, self.noise, self.fault == "clipping",
               None if self._temp is not None else self.temperature_c, self._anchor, self._num, self._den,
               self.vref_tempco)
        c = self._cache
        if c is not None and c[0] == key and c[1] is self._volts and c[2] is self._temp \
                and self._normals_rng is self.rng:
            i, r = divmod(m0 - c[3], d)
            rows = c[5]
            if r == 0 and i >= 0 and i + n <= len(rows) and c[4] + i == self._normals_used:
                self._take_normals(n)
                return rows[i + n - 1]
        first = self._nominal_tick(m0)
        drift = self._num != self._den
        m = n
        if self._batch > 1 and not single:      # single shot: the next START restarts the filter
            grid_end = self._grid_tick0 + (len(self._volts) - 1) * self._step
            ahead = (grid_end - first) // d + 1
            if drift:       # a fast clock fits more conversions in the grid
                ahead = (((grid_end - self._anchor) * self._num) // self._den - m0) // d + 1
            m = max(n, min(self._batch, ahead))
        kw = dict(first_tick=first, n=m)
        if drift:   # the conversions' nominal ticks, on whole ticks (a sinc3 window of nominal length)
            own = m0 + d * np.arange(m, dtype=np.int64)
            kw = dict(ticks=self._anchor - ((-own * self._den) // self._num))
        temp = self._temp if self._temp is not None else self.temperature_c
        codes = convert(self._volts, temp, cfg, step=self._step,
                        rng=NO_NOISE, normals=self._peek_normals(m) if self.noise else None,
                        grid_tick0=self._grid_tick0, clipping=self.fault == "clipping",
                        vref_tempco=self.vref_tempco, **kw)
        rows = codes.tolist()                   # Python ints: a frame is built from one row
        self._cache = (key, self._volts, self._temp, m0, self._normals_used, rows) if m > n else None
        self._take_normals(n)
        return rows[n - 1]

    def _peek_normals(self, m):
        """The next `m` rows of noise normals from `rng`, not yet consumed: (m, 2)."""
        if self._normals_rng is not self.rng:   # rng replaced: draw from the new one
            self._normals, self._normals_rng, self._cache = np.zeros((0, 2)), self.rng, None
            self._normals_off = 0
        if self._normals_off:                   # drop the consumed rows
            self._normals, self._normals_off = self._normals[self._normals_off:], 0
        short = m - len(self._normals)
        if short > 0:
            # draws exactly what is missing: with batch = 1 this is the unbatched draw
            self._normals = np.concatenate([self._normals, self.rng.standard_normal((short, 2))])
        return self._normals[:m]

    def _take_normals(self, n):
        """Consume `n` rows of normals (the conversions they belong to happened)."""
        if self.noise:
            self._normals_off += n
        self._normals_used += n

    def _new_frame(self, codes):
        regs = self.registers
        status = 0xC00000 | (regs[LOFF_STAT] & 0x1F) << 15 | (regs[GPIO] & 0x03) << 13   # status_word
        if self.fault == "status-corrupt" and self._fault_rng.random() < self.fault_rate:
            status ^= 0x300000 | int(self._fault_rng.integers(1 << 13))
        self._set_frame(status, codes)
        self._out_ptr = 0
        self._drdy_low = True

    def _set_frame(self, status, codes):
        # the bytes are built when read: most conversions are replaced unread
        self._frame, self._frame_words = None, (status, codes)

    @property
    def frame(self):
        """The latest conversion's 9-byte frame (status, CH1, CH2)."""
        if self._frame is None:
            self._frame = frame_bytes(*self._frame_words)
        return self._frame

    def _drdy_dead(self):
        return self.fault in _DRDY_DEAD

    # ------------------------------------------------------------------ pins
    @property
    def drdy(self):
        """DRDY pin level: False (low) = new data ready (active low [DS §8.5.1.6])."""
        if self.fault == "drdy-stuck-low":
            return False
        if self._drdy_dead():
            return True
        return not self._drdy_low

    @property
    def start(self):
        """START pin level (True = high: convert)."""
        return self._start_pin

    @start.setter
    def start(self, level):
        level = bool(level)
        if level and not self._start_pin:
            self._begin_conversions()
        elif not level and self._start_pin and not self._start_cmd:
            self._stop_after_next = self._next_drdy is not None  # current conversion completes
        self._start_pin = level

    def select(self, active):
        """Chip select: True drives CS low. CS high resets the serial interface [DS §8.5.1.1]."""
        active = bool(active)
        if not active:
            self._cmd, self._pending_out, self._wreg_left, self._swallow = [], b"", 0, 0
            self._out_ptr = 0
        self._selected = active

    @property
    def selected(self):
        return self._selected

    def pwdn_reset(self, level):
        """PWDN/RESET pin: a falling edge resets the chip; low powers it down [DS §8.5.1.8]."""
        level = bool(level)
        if not level and not self._power_down:
            self._power_on_reset()
            self._power_down = True
        elif level and self._power_down:
            self._power_down = False
            self._busy_until = self.tick + RESET_BUSY_TICKS
            if self._start_pin:
                self._begin_conversions()

    def _begin_conversions(self, delay=0):
        if self.standby or self._power_down:
            self._running = True
            return
        self._running = True
        self._stop_after_next = False
        # the chip's own clock times the settling and every conversion after it
        self._anchor, self._m_next = self.tick, delay + SETTLE_TICKS[min(self.config.dr, 6)]
        self._next_drdy = self._nominal_tick(self._m_next)
        self.start_tick = self.tick + delay

    # ------------------------------------------------------------------- SPI
    def clock(self, nbytes):
        """SCLK runs for `nbytes` while this chip is not selected (shared bus):
        time passes and DRDY returns high on the first falling edge [DS §8.5.1.6]."""
        if nbytes:
            self._drdy_low = False
            self.advance(nbytes * 8 / self.sclk_hz)

    def transfer(self, data):
        """Full-duplex exchange while selected: returns one byte per byte sent.

        While not selected DOUT is tri-state: reads 0xFF (pull-up) and nothing
        is decoded. Each byte advances chip time by 8 / sclk_hz.
        """
        data = bytes(data)
        if not self._selected or self._power_down:
            self.clock(len(data))
            return b"\xff" * len(data)
        n = len(data)
        step = 8 / self.sclk_hz * F_MOD
        if self.rdatac and not (self._pending_out or self._cmd or self._wreg_left or self._swallow) \
                and not any(data) and (self._next_drdy is None or self.standby
                                       or self._next_drdy > self._ticks_f + (n + 1) * step):
            # RDATAC read, DIN low, no conversion completes meanwhile: the frame's bytes in
            # one go, time advanced exactly as byte by byte
            p = self._out_ptr % FRAME_BYTES
            frame = self.frame
            out = (frame[p:] + frame * (n // FRAME_BYTES + 1))[:n]
            self._out_ptr += n
            self._drdy_low = False
            for _ in range(n):
                self._ticks_f += step
            self._run_until(int(self._ticks_f + 1e-6))
        else:
            out = bytearray()
            for b in data:
                self._drdy_low = False          # first SCLK falling edge raises DRDY
                out.append(self._shift(b))
                self.advance(8 / self.sclk_hz)
        if self.fault == "absent-0x00":
            return bytes(len(data))
        if self.fault == "absent-0xff":
            return b"\xff" * len(data)
        if self.fault == "bit-flips":
            bits = np.unpackbits(np.frombuffer(bytes(out), np.uint8))
            bits ^= (self._fault_rng.random(bits.size) < self.fault_rate).astype(np.uint8)
            out = np.packbits(bits).tobytes()
        return bytes(out)

    def _shift(self, b):
        """One byte in, one byte out."""
        if self._pending_out:                   # RREG data / RDATA frame
            o, self._pending_out = self._pending_out[0], self._pending_out[1:]
            return o
        if self.rdatac:
            o = self.frame[self._out_ptr % FRAME_BYTES]
            self._out_ptr += 1
        else:
            o = 0x00
        self._decode(b)
        return o

    def _decode(self, b):
        if self._swallow:
            self._swallow -= 1
            return
        if self._wreg_left:
            addr = self._cmd[0] & 0x1F
            self._write_register(addr + len(self._cmd) - 2, b)
            self._cmd.append(b)
            self._wreg_left -= 1
            if not self._wreg_left:
                self._cmd = []
            return
        if self._cmd:                            # count byte of RREG / WREG
            op = self._cmd[0]
            count = (b & 0x1F) + 1
            addr = op & 0x1F
            if op & 0xE0 == RREG:
                self._cmd = []
                if self.rdatac:
                    self._violate("RREG ignored in RDATAC mode: send SDATAC first [DS §8.5.2.7]")
                    return
                regs = [self._read_register(a) for a in range(addr, addr + count)]
                self._pending_out = bytes(regs)
            else:
                self._cmd.append(b)
                if self.rdatac:
                    self._violate("WREG ignored in RDATAC mode: send SDATAC first [DS §8.5.2.7]")
                    self._cmd, self._wreg_left = [], 0
                    self._swallow = count            # its data bytes are not commands
                    return
                self._wreg_left = count
            return
        if b == 0x00:
            return                               # DIN idle while reading
        if self.tick < self._busy_until:
            self._violate("command 0x%02X %d ticks too early (after power-up/RESET/previous command)"
                          % (b, self._busy_until - self.tick))
            if self.strict:
                return
        if self.standby and b != WAKEUP:
            self._violate("only WAKEUP may follow STANDBY [DS §8.5.2.2]; got 0x%02X" % b)
            return
        if b & 0xE0 in (RREG, WREG):
            self._cmd = [b]
            return
        self._busy_until = self.tick + DECODE_TICKS
        if b == WAKEUP:
            if self.standby:
                self.standby = False
                if self._running:
                    self._begin_conversions(delay=WAKE_TICKS)
        elif b == STANDBY:
            self.standby = True
            self._m_next = self._next_drdy = None
        elif b == RESET:
            start_pin = self._start_pin
            self._power_on_reset()
            self._busy_until = self.tick + RESET_BUSY_TICKS
            if start_pin:
                self._begin_conversions(delay=RESET_BUSY_TICKS)
        elif b == START:
            if self._start_pin:
                self._violate("START command with START pin high: hold the pin low [DS §8.5.2.4]")
            self._start_cmd = True
            self._begin_conversions()
        elif b == STOP:
            self._start_cmd = False
            if not self._start_pin:
                self._stop_after_next = self._next_drdy is not None
        elif b == RDATAC:
            self.rdatac = True
            self._out_ptr = 0
        elif b == SDATAC:
            self.rdatac = False
        elif b == RDATA:
            if self.rdatac:
                self._violate("RDATA in RDATAC mode")
            self._pending_out = self.frame
        elif b == OFFSETCAL:
            pass                                 # offset calibration: offsets are not modelled
        else:
            self._violate("unknown opcode 0x%02X" % b)

    def _read_register(self, addr):
        if addr >= N_REGISTERS:
            return 0x00
        return self.registers[addr]

    def _write_register(self, addr, value):
        if addr >= N_REGISTERS or addr == ID:
            self._violate("WREG to read-only/unknown address 0x%02X" % addr)
            return
        mask = WRITABLE[addr]
        fixed = FIXED[addr] & ~mask & 0xFF        # bits that "must be" 0 or 1 [DS §8.6.1]
        if value & ~mask & 0xFF != fixed:
            self._violate("register 0x%02X written 0x%02X: its fixed bits must read 0x%02X"
                          % (addr, value, fixed))
        self.registers[addr] = fixed | (value & mask)
        if addr == CONFIG1 and self._running and self._next_drdy is not None:
            self._begin_conversions()            # writing CONFIG1 resets the digital filter [DS §8.5.1.8]
        if addr == CONFIG1 and value & 0x07 == 0x07:
            self._violate("CONFIG1 DR=111 is 'do not use'")
        if addr in (CH1SET, CH2SET) and (value >> 4) & 0x07 == 0x07:
            self._violate("CH%dSET gain code 111 is not defined" % (addr - 3))

    def _violate(self, text):
        self.violations.append("t=%.6f s: %s" % (self.time, text))
