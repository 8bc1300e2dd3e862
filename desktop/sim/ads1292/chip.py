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

The chip's state machine and SPI bytes are here (commands and registers in
commands.py); the analog world feeding it is `chip.analog` (analog.py: inputs,
temperature, noise), whose codes come from convert.py (the vectorised path, the
same arithmetic), so a capture and a byte-level run of the same grid agree code
for code; the oscillator and the DRDY schedule are `chip.schedule` (clock.py).
Time is counted in modulator ticks tMOD = 1 / 128 kHz (internal 512 kHz
oscillator, CLK_DIV=0, fMOD = fCLK / 4 [DS §8.3.7]); every event (START, DRDY,
byte transfers) lands on an integer tick, so the byte path and the vectorised
path agree exactly on which analog samples each conversion sees.
"""

import math

import numpy as np

from desktop.sim.ads1292.analog import AnalogInput
from desktop.sim.ads1292.clock import ConversionSchedule
from desktop.sim.ads1292.commands import CommandDecoder
from desktop.sim.ads1292.faults import (DEFAULT_FAULT_RATES, DRDY_DEAD, FAULTS, checked_rate, corrupt_status,
                                        dout_bytes, oscillator_ratio)
from desktop.sim.ads1292.registers import (F_MOD, FRAME_BYTES, GPIO, ID, LOFF_STAT, RESET_BUSY_TICKS,
                                           RESET_VALUES, SETTLE_TICKS, T_POR_TICKS, Config, frame_bytes,
                                           status_word)

__all__ = ["ADS1292", "FAULTS", "DEFAULT_FAULT_RATES"]


class ADS1292(CommandDecoder):
    """One ADS1292 on an SPI bus (mode 1), emulated byte by byte.

    The chip's state machine (pins, SPI bytes, commands, registers) is this class
    and commands.py; what feeds it is :attr:`analog` (:class:`AnalogInput`: the
    inputs, die temperature and noise, turned into codes) and what times it is
    :attr:`schedule` (:class:`ConversionSchedule`: the oscillator and DRDY).

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
        :attr:`AnalogInput.batch`); 1 computes each when its DRDY comes due. Any
        value gives the same codes, DRDY ticks, frames, faults and violations.
    vref_tempco : float
        The internal reference's drift, relative per C about 25 C (within
        +-45e-6 [DS §6.5]; see :func:`convert`); 0 (default): none.
    """

    def __init__(self, chip_id=0x53, *, seed=None, fault=None, fault_rate=None,
                 sclk_hz=1_000_000, strict=True, noise=True, batch=1, vref_tempco=0.0):
        self.chip_id = chip_id
        self.fault, self.fault_rate = None, 0.01
        self.schedule = ConversionSchedule()
        self._cfg_regs, self._cfg = None, None   # Config of the register map, decoded once
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self.analog = AnalogInput(rng, noise=noise, vref_tempco=vref_tempco)
        self.set_fault(fault, fault_rate)
        # faults draw from a child stream so they never shift the noise sequence
        self._fault_rng = np.random.default_rng(rng.bit_generator.seed_seq.spawn(1)[0])
        self.sclk_hz = float(sclk_hz)
        self.strict = strict
        self.violations = []
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
        self.schedule.stop()
        self._stop_after_next = False
        self._set_frame(status_word(0, self.registers[GPIO] & 0x03), (0, 0))
        self._out_ptr = 0
        self._reset_decoder()

    @property
    def config(self):
        """The current register map decoded (:class:`Config`); decoded again only after a change."""
        regs = tuple(self.registers)
        if regs != self._cfg_regs:
            self._cfg_regs, self._cfg = regs, Config(regs)
        return self._cfg

    # ------------------------------------------- the analog world (analog.py)
    def load(self, volts, rate_hz=16000, t0=0.0, temperature_c=None):
        """Feed the analog inputs over time: :meth:`AnalogInput.load`."""
        self.analog.load(volts, rate_hz, t0, temperature_c)

    rng = property(lambda self: self.analog.rng, lambda self, v: setattr(self.analog, "rng", v),
                   doc="The ADC noise's Generator (settable).")
    noise = property(lambda self: self.analog.noise, lambda self, v: setattr(self.analog, "noise", v),
                     doc="False: no input-referred noise (settable).")
    temperature_c = property(lambda self: self.analog.temperature_c,
                             lambda self, v: setattr(self.analog, "temperature_c", v),
                             doc="Die temperature (C) when no temperature grid is loaded (settable).")
    vref_tempco = property(lambda self: self.analog.vref_tempco,
                           lambda self, v: setattr(self.analog, "vref_tempco", v),
                           doc="The internal reference's relative drift per C (settable).")
    batch = property(lambda self: self.analog.batch, lambda self, v: setattr(self.analog, "batch", v),
                     doc="Conversions computed ahead per convert() call: :attr:`AnalogInput.batch`.")

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
        rate = checked_rate(fault, rate)
        self.fault, self.fault_rate = fault, rate
        self.schedule.set_ratio(oscillator_ratio(fault, rate))
        self.analog.drop_cache()

    @property
    def clock_ratio(self):
        """The oscillator's frequency over the nominal 512 kHz (1 + the clock-drift rate)."""
        return self.schedule.ratio

    def _drdy_dead(self):
        return self.fault in DRDY_DEAD

    # ------------------------------------------------------------------ time
    @property
    def time(self):
        """Chip time since power-up, s."""
        return self.tick / F_MOD

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
        next_drdy = self.schedule.next_drdy
        if self._drdy_dead() or next_drdy is None or self.standby or next_drdy > deadline:
            self.advance_to_tick(deadline)
            raise TimeoutError("no DRDY within %.6f s" % timeout)
        return next_drdy

    @property
    def stopping(self):
        """The next conversion is the last one (single shot, STOP, START low) [DS §8.5.1.10]."""
        return self._stop_after_next or self.config.single_shot

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
        """Complete every conversion due by tick `target` (the unread ones are replaced
        by the last), then stand at `target`."""
        s = self.schedule
        while s.next_drdy is not None and s.next_drdy <= target and not self.standby:
            cfg = self.config
            d = cfg.decimation
            single = cfg.single_shot or self._stop_after_next
            n = 1 if single else s.due_by(target, d)
            last = self.analog.codes(cfg, self._cfg_regs, s, n, single, self.fault == "clipping")
            self.tick = s.complete(n, d)
            self.conversions += n
            self._new_frame(last)
            if not self._drdy_dead():
                self.drdy_falls += n           # a dead DRDY pin makes no edges
            if single:
                s.stop()                       # single shot: DRDY stays low [DS §8.5.1.10]
                self._running = self._start_cmd = False
                self._stop_after_next = False
        if target > self.tick:
            self.tick = target

    def _begin_conversions(self, delay=0):
        if self.standby or self._power_down:
            self._running = True
            return
        self._running = True
        self._stop_after_next = False
        # the chip's own clock times the settling and every conversion after it
        self.schedule.start(self.tick, delay + SETTLE_TICKS[min(self.config.dr, 6)])
        self.start_tick = self.tick + delay

    # ---------------------------------------------------------------- frames
    def _new_frame(self, codes):
        regs = self.registers
        status = 0xC00000 | (regs[LOFF_STAT] & 0x1F) << 15 | (regs[GPIO] & 0x03) << 13   # status_word
        if self.fault == "status-corrupt":
            status = corrupt_status(status, self._fault_rng, self.fault_rate)
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
            # the current conversion completes
            self._stop_after_next = self.schedule.next_drdy is not None
        self._start_pin = level

    def select(self, active):
        """Chip select: True drives CS low. CS high resets the serial interface [DS §8.5.1.1]."""
        active = bool(active)
        if not active:
            self._reset_decoder()
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
        next_drdy = self.schedule.next_drdy
        if self.rdatac and self._decoder_idle() and not any(data) \
                and (next_drdy is None or self.standby or next_drdy > self._ticks_f + (n + 1) * step):
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
        return dout_bytes(out, self.fault, self._fault_rng, self.fault_rate)

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

    def _violate(self, text):
        self.violations.append("t=%.6f s: %s" % (self.time, text))
