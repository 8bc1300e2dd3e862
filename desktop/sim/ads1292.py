"""TI ADS1292 emulator: one chip on its SPI bus, byte by byte, plus the same
conversion arithmetic vectorised over a whole capture.

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

Usage (vectorised, a whole capture at once, same codes)::

    codes = convert(volts, None, config, first_tick=..., n=..., rng=rng)

Time is counted in modulator ticks tMOD = 1 / 128 kHz (internal 512 kHz
oscillator, CLK_DIV=0, fMOD = fCLK / 4 [DS §8.3.7]); every event (START, DRDY,
byte transfers) lands on an integer tick, so the byte path and the vectorised
path agree exactly on which analog samples each conversion sees.
"""

import numpy as np

# --- clocks [DS §6.5, §8.3.7] ---------------------------------------------
F_CLK = 512_000                 # Hz, internal oscillator
F_MOD = F_CLK // 4              # Hz, modulator clock (CLK_DIV=0)
T_POR_TICKS = 1 << 12           # power-on reset, 2^12 tMOD = 32 ms [DS §10.1]
RESET_BUSY_TICKS = 9            # RESET: 9 fMOD cycles (the longer of two figures) [DS §8.5.2.3]
DECODE_TICKS = 1                # 4 tCLK = 1 tMOD before the next command [DS §8.5.2]
WAKE_TICKS = F_MOD // 100       # first DRDY 10 ms after STANDBY [DS §6.5]

# --- commands [DS §8.5.2 Table 15] ----------------------------------------
WAKEUP = 0x02
STANDBY = 0x04
RESET = 0x06
START = 0x08
STOP = 0x0A
OFFSETCAL = 0x1A
RDATAC = 0x10
SDATAC = 0x11
RDATA = 0x12
RREG = 0x20                     # | address; 2nd byte = count - 1
WREG = 0x40                     # | address; 2nd byte = count - 1, then data

# --- register map [DS §8.6 Table 16] --------------------------------------
ID, CONFIG1, CONFIG2, LOFF, CH1SET, CH2SET = 0x00, 0x01, 0x02, 0x03, 0x04, 0x05
RLD_SENS, LOFF_SENS, LOFF_STAT, RESP1, RESP2, GPIO = 0x06, 0x07, 0x08, 0x09, 0x0A, 0x0B
N_REGISTERS = 12
# Reset values; ID is the chip's own (0x53 for an ADS1292).
RESET_VALUES = (0x53, 0x02, 0x80, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x0C)
# Bits a WREG can change, and the value the fixed bits always hold.
#            ID    CFG1  CFG2  LOFF  CH1   CH2   RLD   LSENS LSTAT RESP1 RESP2 GPIO
WRITABLE = (0x00, 0x87, 0x7B, 0xED, 0xFF, 0xFF, 0xFF, 0x3F, 0x40, 0xFD, 0x87, 0x0F)
FIXED = (0x00, 0x00, 0x80, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00)
# CONFIG2 bits [DS §8.6.1.3]
PDB_REFBUF, VREF_4V, INT_TEST, TEST_FREQ = 0x20, 0x10, 0x02, 0x01
CONFIG1_SINGLE_SHOT = 0x80

# --- data rates, gains, MUX [DS §8.6.1.2, §8.6.1.5] -----------------------
DECIMATION = (1024, 512, 256, 128, 64, 32, 16)        # DR 000..110: fMOD / N
DATA_RATES = tuple(F_MOD // d for d in DECIMATION)    # 125 .. 8000 SPS
SETTLE_TICKS = (4100, 2052, 1028, 516, 260, 132, 68)  # START to 1st DRDY [DS §8.5.1.10]
GAINS = (6, 1, 2, 3, 4, 8, 12)                        # GAINn[6:4] 000..110
MUX_NORMAL, MUX_SHORT, MUX_SUPPLY, MUX_TEMP, MUX_TEST = 0x0, 0x1, 0x3, 0x4, 0x5
VREF_LOW, VREF_HIGH = 2.42, 4.033                     # V [DS §8.3.6]
FULL_SCALE_CODE = (1 << 23) - 1                       # LSB = VREF / (2^23 - 1) [DS §8.3.8]
# Input-referred noise at gain 6, 2.42 V reference, per data rate, uVrms [DS §7.1].
NOISE_UV_GAIN6 = (0.5, 0.7, 0.9, 1.3, 2.2, 7.5, 42.7)
# Supplies assumed for the supply-monitor MUX setting [DS §8.6.1.5].
AVDD, DVDD = 3.0, 3.0
# Temperature sensor: 145.3 mV at 25 C, 490 uV/C [DS §8.3.2.4 Eq.3]
TEMP_V25, TEMP_V_PER_C = 145.3e-3, 490e-6

FRAME_BYTES = 9                 # 24 status bits + 2 x 24 data bits [DS §8.5.1.5]
FAULTS = ("absent-0x00", "absent-0xff", "drdy-stuck-high", "drdy-stuck-low",
          "status-corrupt", "bit-flips", "clipping")


def noise_gain_factor(gain):
    """Input-referred ADC noise at `gain` relative to gain 6.

    Model noise(G) = sqrt(a^2 + (b/G)^2) fitted to the 500 SPS rows of [DS §7.1]
    (3.0 uV at G=1, 0.9 at G=6; it predicts 0.80 at G=12, the table says 0.8).
    """
    return np.sqrt(0.576 + 8.424 / gain ** 2) / 0.9


def temperature_volts(temp_c):
    """Internal temperature sensor output (V) at `temp_c` (C) [DS Eq.3]."""
    return TEMP_V25 + TEMP_V_PER_C * (np.asarray(temp_c, dtype=float) - 25.0)


def volts_to_temperature(volts):
    """Inverse of :func:`temperature_volts`: channel volts (input-referred) to C."""
    return (np.asarray(volts, dtype=float) - TEMP_V25) / TEMP_V_PER_C + 25.0


def codes_to_volts(codes, gain, vref=VREF_LOW):
    """Input-referred volts of 24-bit codes: LSB = VREF / (2^23 - 1) / gain [DS §8.3.8]."""
    return np.asarray(codes, dtype=float) * (vref / FULL_SCALE_CODE / gain)


class Config:
    """The conversion-relevant part of a register map, decoded.

    Parameters
    ----------
    registers : sequence of 12 ints
        Register values as read by RREG (index = address).
    """

    def __init__(self, registers):
        r = list(registers)
        self.dr = r[CONFIG1] & 0x07
        self.single_shot = bool(r[CONFIG1] & CONFIG1_SINGLE_SHOT)
        self.vref = VREF_HIGH if r[CONFIG2] & VREF_4V else VREF_LOW
        self.int_test = bool(r[CONFIG2] & INT_TEST)
        self.test_1hz = bool(r[CONFIG2] & TEST_FREQ)
        chs = (r[CH1SET], r[CH2SET])
        self.power_down = tuple(bool(c & 0x80) for c in chs)
        self.gain = tuple(GAINS[(c >> 4) & 0x07] if (c >> 4) & 0x07 < 7 else 6 for c in chs)
        self.mux = tuple(c & 0x0F for c in chs)

    @classmethod
    def default(cls, dr=5, gain=1, mux=(MUX_NORMAL, MUX_NORMAL), vref_4v=False):
        """The configuration :func:`standard_registers` describes."""
        return cls(standard_registers(dr, gain, mux, vref_4v))

    @property
    def decimation(self):
        """Modulator ticks per conversion."""
        return DECIMATION[min(self.dr, 6)]

    @property
    def rate(self):
        """Output data rate, SPS."""
        return F_MOD // self.decimation


def standard_registers(dr=5, gain=1, mux=(MUX_NORMAL, MUX_NORMAL), vref_4v=False):
    """Register map (12 values) of a chip configured for this instrument.

    Internal reference buffer on (CONFIG2 = 0xA0 [DS §8.3.11]), data rate code
    `dr`, both channels at `gain` with the given MUX settings, RESP1 = 0x02 and
    RESP2.RESP_FREQ = 1 as the ADS1292 requires [DS §8.6.1.10-11].
    """
    r = list(RESET_VALUES)
    r[CONFIG1] = dr
    r[CONFIG2] = 0x80 | PDB_REFBUF | (VREF_4V if vref_4v else 0)
    code = GAINS.index(gain)
    r[CH1SET] = (code << 4) | mux[0]
    r[CH2SET] = (code << 4) | mux[1]
    r[RESP1] = 0x02
    r[RESP2] = 0x06
    return r


def sinc3_kernel(decimation, step, phase):
    """Weights of the sinc3 decimator on an analog grid coarser than fMOD.

    The chip's digital filter is three cascaded boxcars of `decimation` modulator
    samples (-3 dB at 0.262 fDR [DS Eq.5]): an impulse response of 3D - 2 taps.
    The emulator's analog input is held constant over `step` modulator ticks,
    so each grid sample's weight is the sum of the taps that fall on it.

    Parameters
    ----------
    decimation : int
        fMOD / fDR.
    step : int
        Modulator ticks per analog grid sample (divides 16).
    phase : int
        Tick of the conversion within its grid sample, 0 <= phase < step.

    Returns
    -------
    (J,) float64 array
        Weight of grid sample g_T - j, j = 0..J-1, where g_T holds the DRDY tick.
    """
    box = np.ones(decimation)
    taps = np.convolve(np.convolve(box, box), box)
    taps /= taps.sum()
    j = (np.arange(taps.size) - phase + step - 1) // step   # grid samples back
    return np.bincount(j, weights=taps)


def channel_input(x, mux, channel, cfg, temp_c, ticks):
    """Differential input (V) a channel sees for its MUX setting [DS §8.6.1.5].

    `x` is the sinc3-filtered analog input of the channel (V) and `temp_c` the
    filtered die temperature (C), both (N,) arrays at the conversion ticks.
    """
    if mux == MUX_NORMAL:
        return x
    if mux == MUX_TEMP:
        return temperature_volts(temp_c)
    if mux == MUX_SUPPLY:
        # CH1 reads (AVDD + AVSS) / 2, CH2 DVDD / 4 (text; the table is inconsistent).
        return np.full(x.shape, (AVDD / 2) if channel == 0 else (DVDD / 4))
    if mux == MUX_TEST and cfg.int_test:
        amp = cfg.vref / 2400.0                               # +-(VREFP - VREFN) / 2400
        if cfg.test_1hz:
            return np.where((ticks // (F_MOD // 2)) % 2 == 0, amp, -amp)
        return np.full(x.shape, amp)
    return np.zeros(x.shape)                                  # short, RLD, test off, IN3


def convert(volts, temp_c, cfg, *, first_tick, n, rng, step=8, grid_tick0=0,
            clipping=False, normals=None):
    """Vectorised conversion results of a continuously running chip.

    Parameters
    ----------
    volts : (G, 2) float array, V
        Analog differential input of CH1, CH2 on a grid of `step` modulator
        ticks per sample starting at tick `grid_tick0`; held at the edges.
    temp_c : (G,) float array or float or None
        Die temperature (C) on the same grid (None: 25 C).
    cfg : Config
    first_tick : int
        Modulator tick of the first DRDY; later ones follow every decimation.
    n : int
        Number of conversions.
    rng : numpy.random.Generator
        Draws the ADC's input-referred noise, (n, 2) normals in conversion order.
    clipping : bool
        Fault injection: drive CH1 beyond positive full scale.
    normals : (n, 2) float array or None
        Standard normals for the noise, row i for conversion i; None draws them
        from `rng` (which is then not used). A Generator's normals come in the
        same order however they are split into calls, so codes computed from
        rows of one larger draw equal codes computed draw by draw.

    Returns
    -------
    (n, 2) int32 array
        24-bit two's complement codes, clipped to [-2^23, 2^23 - 1].
    """
    d = cfg.decimation
    if d % step:
        raise ValueError("analog grid step %d does not divide decimation %d" % (step, d))
    rel = first_tick - grid_tick0
    w = sinc3_kernel(d, step, rel % step)
    g = rel // step + np.arange(n) * (d // step)               # grid sample of each DRDY
    volts = np.asarray(volts, dtype=float)
    last = volts.shape[0] - 1
    x = np.zeros((n, 2))
    t = np.zeros(n)
    temp = None if temp_c is None or np.ndim(temp_c) == 0 else np.asarray(temp_c, float)
    for j, wj in enumerate(w):                                 # taps, not samples
        idx = np.clip(g - j, 0, last)
        x += wj * volts[idx]
        if temp is not None:
            t += wj * temp[idx]
    if temp is None:
        t[:] = 25.0 if temp_c is None else float(temp_c)
    ticks = first_tick + np.arange(n, dtype=np.int64) * d
    if normals is None:
        normals = rng.standard_normal((n, 2))
    noise = normals * (NOISE_UV_GAIN6[min(cfg.dr, 6)] * 1e-6)
    out = np.zeros((n, 2), dtype=np.int32)
    for ch in range(2):
        if cfg.power_down[ch]:
            continue                                           # reads 0, keeps its slot [DS §8.5.1.5]
        v = channel_input(x[:, ch], cfg.mux[ch], ch, cfg, t, ticks)
        if clipping and ch == 0:
            v = v + 2.0 * cfg.vref / cfg.gain[ch]
        v = v + noise[:, ch] * noise_gain_factor(cfg.gain[ch])
        code = np.rint(v * (cfg.gain[ch] * FULL_SCALE_CODE / cfg.vref))
        out[:, ch] = np.clip(code, -(1 << 23), FULL_SCALE_CODE)  # clips at +-FS [DS §8.3.8]
    return out


def status_word(loff_stat, gpio):
    """24-bit status: 1100 + LOFF_STAT[4:0] + GPIO[1:0] + 13 zeros [DS §8.5.1.5]."""
    return 0xC00000 | (loff_stat & 0x1F) << 15 | (gpio & 0x03) << 13


def frame_bytes(status, codes):
    """The 9-byte RDATAC frame: status then CH1, CH2, 24-bit MSB first."""
    out = bytearray()
    for word in (status, int(codes[0]) & 0xFFFFFF, int(codes[1]) & 0xFFFFFF):
        out += bytes(((word >> 16) & 0xFF, (word >> 8) & 0xFF, word & 0xFF))
    return bytes(out)


def parse_frame(frame):
    """(status, ch1, ch2) of a 9-byte frame; channels sign-extended from 24 bits."""
    words = [int.from_bytes(frame[i:i + 3], "big") for i in (0, 3, 6)]
    return words[0], [(w ^ 0x800000) - 0x800000 for w in words[1:]]


def parse_frames(raw):
    """Vectorised :func:`parse_frame`: (N, 9) uint8 -> (status (N,), codes (N, 2) int32)."""
    raw = np.asarray(raw, dtype=np.int32).reshape(-1, 3, 3)
    words = (raw[:, :, 0] << 16) | (raw[:, :, 1] << 8) | raw[:, :, 2]
    codes = ((words[:, 1:] ^ 0x800000) - 0x800000).astype(np.int32)
    return words[:, 0], codes


class _NoNoise:
    """Stands in for a Generator when the ADC's noise is switched off."""

    @staticmethod
    def standard_normal(shape):
        return np.zeros(shape)


NO_NOISE = _NoNoise()


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
        One of FAULTS (see docs/simulator.md).
    fault_rate : float
        Probability per frame ("status-corrupt") or per bit ("bit-flips").
    sclk_hz : float
        SPI clock: each transferred byte takes 8 / sclk_hz of chip time.
    strict : bool
        Ignore commands that break the datasheet's timing rules (they are
        always recorded in `violations`).
    batch : int
        Conversions computed per vectorised :func:`convert` call (see
        :attr:`batch`); 1 computes each when its DRDY comes due. Any value
        gives the same codes, DRDY ticks, frames, faults and violations.
    """

    def __init__(self, chip_id=0x53, *, seed=None, fault=None, fault_rate=None,
                 sclk_hz=1_000_000, strict=True, noise=True, batch=1):
        if fault is not None and fault not in FAULTS:
            raise ValueError("unknown fault %r (one of %s)" % (fault, ", ".join(FAULTS)))
        self.chip_id = chip_id
        self.fault = fault
        self.fault_rate = fault_rate if fault_rate is not None else (
            1e-4 if fault == "bit-flips" else 0.01)
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
        self._next_drdy = None
        self._stop_after_next = False
        self.frame = frame_bytes(status_word(0, self._gpio_bits()), (0, 0))
        self._out_ptr = 0
        self._cmd = []                 # bytes of a multi-byte command in progress
        self._pending_out = b""       # RREG / RDATA output queued for next bytes
        self._wreg_left = 0
        self._swallow = 0

    def _gpio_bits(self):
        return self.registers[GPIO] & 0x03 if hasattr(self, "registers") else 0

    @property
    def config(self):
        """The current register map decoded (:class:`Config`)."""
        return Config(self.registers)

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
        end = int(np.ceil(self._ticks_f + timeout * F_MOD - 1e-6))
        return max(end, self.tick + 1)

    def next_drdy_tick(self, timeout=1.0):
        """Tick of the next DRDY falling edge if it comes by
        :meth:`deadline_tick` (`timeout`); otherwise advance to that deadline
        and raise TimeoutError (not started, standby, chip absent, DRDY stuck,
        or the next DRDY is later)."""
        deadline = self.deadline_tick(timeout)
        if self._drdy_dead() or self._next_drdy is None or self.standby \
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
            n = 1 if single else (target - self._next_drdy) // d + 1
            codes = self._codes(cfg, self._next_drdy, n, single)
            self.tick = self._next_drdy + (n - 1) * d
            self.conversions += n
            self._new_frame(codes[-1])
            self.drdy_falls += n
            if cfg.single_shot or self._stop_after_next:
                self._next_drdy = None         # single shot: DRDY stays low [DS §8.5.1.10]
                self._running = self._start_cmd = False
                self._stop_after_next = False
            else:
                self._next_drdy = self.tick + d
        self.tick = max(self.tick, target)

    def _codes(self, cfg, first, n, single):
        """(n, 2) codes of the conversions at ticks first + i * decimation, i < n.

        Served from the batch cache when it holds them, was computed for the
        same inputs and its noise rows are the next unused ones; else computed
        with up to `batch` conversions ahead (see :attr:`batch`).
        """
        d = cfg.decimation
        temp = self._temp if self._temp is not None else self.temperature_c
        # everything convert() reads besides the tick and the noise rows
        key = (tuple(self.registers), self._step, self._grid_tick0, self.noise,
               self.fault == "clipping", None if self._temp is not None else self.temperature_c)
        c = self._cache
        if c is not None and c[0] == key and c[1] is self._volts and c[2] is self._temp \
                and self._normals_rng is self.rng:
            i, r = divmod(first - c[3], d)
            if r == 0 and i >= 0 and i + n <= len(c[5]) and c[4] + i == self._normals_used:
                self._take_normals(n)
                return c[5][i:i + n]
        m = n
        if self._batch > 1 and not single:      # single shot: the next START restarts the filter
            grid_end = self._grid_tick0 + (len(self._volts) - 1) * self._step
            m = max(n, min(self._batch, (grid_end - first) // d + 1))
        codes = convert(self._volts, temp, cfg, first_tick=first, n=m, step=self._step,
                        rng=NO_NOISE, normals=self._peek_normals(m) if self.noise else None,
                        grid_tick0=self._grid_tick0, clipping=self.fault == "clipping")
        self._cache = (key, self._volts, self._temp, first, self._normals_used, codes) if m > n else None
        self._take_normals(n)
        return codes[:n]

    def _peek_normals(self, m):
        """The next `m` rows of noise normals from `rng`, not yet consumed: (m, 2)."""
        if self._normals_rng is not self.rng:   # rng replaced: draw from the new one
            self._normals, self._normals_rng, self._cache = np.zeros((0, 2)), self.rng, None
        short = m - len(self._normals)
        if short > 0:
            # draws exactly what is missing: with batch = 1 this is the unbatched draw
            self._normals = np.concatenate([self._normals, self.rng.standard_normal((short, 2))])
        return self._normals[:m]

    def _take_normals(self, n):
        """Consume `n` rows of normals (the conversions they belong to happened)."""
        if self.noise:
            self._normals = self._normals[n:]
        self._normals_used += n

    def _new_frame(self, codes):
        status = status_word(self.registers[LOFF_STAT], self.registers[GPIO] & 0x03)
        if self.fault == "status-corrupt" and self._fault_rng.random() < self.fault_rate:
            status ^= 0x300000 | int(self._fault_rng.integers(1 << 13))
        self.frame = frame_bytes(status, codes)
        self._out_ptr = 0
        self._drdy_low = True

    def _drdy_dead(self):
        return self.fault in ("absent-0x00", "absent-0xff", "drdy-stuck-high", "drdy-stuck-low")

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
        self._next_drdy = self.tick + delay + SETTLE_TICKS[min(self.config.dr, 6)]
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
            self._next_drdy = None
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


class SPIBus:
    """Several chips on one SPI bus with separate chip selects and a shared START.

    Every byte clocked reaches every chip: the selected one answers, the others
    only see SCLK (their DRDY returns high [DS §8.5.1.6]) and time passes for all.
    """

    def __init__(self, chips):
        self.chips = list(chips)

    def select(self, index):
        """Drive CS of chip `index` low (None: all high)."""
        for i, chip in enumerate(self.chips):
            chip.select(i == index)

    def transfer(self, data):
        """Full-duplex transfer with the selected chip; 0xFF if none is selected."""
        data = bytes(data)
        selected = [c for c in self.chips if c.selected]
        if len(selected) > 1:
            for c in selected:
                c._violate("bus contention: more than one chip selected")
        out = None
        for chip in self.chips:
            if chip.selected:
                got = chip.transfer(data)
                out = got if out is None else bytes(a & b for a, b in zip(out, got))
            else:
                chip.clock(len(data))
        return out if out is not None else b"\xff" * len(data)

    @property
    def start(self):
        return self.chips[0].start

    @start.setter
    def start(self, level):
        for chip in self.chips:
            chip.start = level

    def advance(self, seconds):
        """Let time pass for every chip."""
        for chip in self.chips:
            chip.advance(seconds)

    def wait_drdy(self, index=0, timeout=1.0):
        """Advance all chips to the next DRDY of chip `index` (the one wired to
        the MCU); return the seconds waited. TimeoutError as ADS1292.wait_drdy,
        with every chip at chip `index`'s deadline tick."""
        chip = self.chips[index]
        start = chip.tick
        try:
            tick = chip.next_drdy_tick(timeout)
        except TimeoutError:                 # chip is at its deadline tick: the others follow
            for other in self.chips:
                if other is not chip:
                    other.advance_to_tick(chip.tick)
            raise
        for c in self.chips:
            c.advance_to_tick(tick)
        return (tick - start) / F_MOD
