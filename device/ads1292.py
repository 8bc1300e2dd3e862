"""TI ADS1292 driver: two chips on one SPI bus, one shared START line.

    adc = ADS1292Pair(board, rate=2000, gains=(1, 1, 1))
    adc.begin()                 # reset, probe IDs, configure, verify, RDATAC
    board.attach_drdy(adc.isr)  # DRDY of chip 0 -> adc.isr (hard IRQ, or polled)
    adc.set_decimation(decim=20, window=5)   # boxcar of 5 frames out of every 20
    ... main loop: adc.ring holds boxcar sums (x, y, z, t, block number)

Chip 0 digitises X (CH1) and Y (CH2); chip 1 digitises Z (CH1) and its
internal temperature sensor (CH2, MUX=0100). Section numbers refer to the
datasheet (SBAS502C); see shared/reference/ads1292-and-runtimes.md.

`isr` must not allocate: it runs as a hard interrupt on rp2/stm32. It does the
boxcar decimation itself, so the main loop wakes once per decimated sample,
not once per conversion (on a 133 MHz M0+ a main-loop pass costs ~1 ms):
frames before the window of each block of `decim` frames are not read at all
(in RDATAC an unread result is replaced by the next one and DRDY pulses again,
[E2E-915796] in the fact sheet), the `window` frames at the end of the block
are read into preallocated buffers, the status nibble checked, sign-extended
with shifts and summed (|sum| <= window * 2**23 <= 2**29 for window <= 64,
inside the small-int range). A finished block goes into an array('i') ring as
five ints (x, y, z, temperature sums, block number). A full ring drops the
block and counts it; a block with a bad status header is discarded and counted.

Polled DRDY (CircuitPython): conversions that come and go while the main loop
is busy never reach `isr`. The HAL measures the time since the last serviced
DRDY and calls `account_gap(frames)` from the main loop before the handler, so
the frame counter and the boxcar phase stay in step with the chip and a boxcar
never sums frames from both sides of a gap. Every completed block number is
accounted for: pushed to the ring, dropped (`OVERFLOW`) or thrown away
(`DISCARDED`: a bad header, or a DRDY gap).
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython: const is the identity
    def const(x):
        return x

# Commands, §8.5.2 Table 15
_WAKEUP = const(0x02)
_RESET = const(0x06)
_START = const(0x08)
_STOP = const(0x0A)
_RDATAC = const(0x10)  # read data continuously (power-up default)
_SDATAC = const(0x11)  # stop RDATAC: required before register access
_RREG = const(0x20)    # | address; next byte = count - 1
_WREG = const(0x40)    # | address; next byte = count - 1, then data

# Registers, §8.6 Table 16
_ID = const(0x00)        # REV_ID[7:5] 1 0 0 REV_ID[1:0]: 0x53 for ADS1292
_CONFIG1 = const(0x01)   # SINGLE_SHOT(7) 0000 DR[2:0]
_CONFIG2 = const(0x02)   # 1(7) PDB_LOFF_COMP(6) PDB_REFBUF(5) VREF_4V(4) CLK_EN(3) 0 INT_TEST(1) TEST_FREQ(0)
_LOFF = const(0x03)      # COMP_TH[7:5] 1(4) ILEAD_OFF[3:2] 0 FLEAD_OFF(0)
_CH1SET = const(0x04)    # PD1(7) GAIN1[6:4] MUX1[3:0]
_CH2SET = const(0x05)    # PD2(7) GAIN2[6:4] MUX2[3:0]
_RLD_SENS = const(0x06)
_LOFF_SENS = const(0x07)
_LOFF_STAT = const(0x08)
_RESP1 = const(0x09)     # must be written 0x02 on ADS1292 (§8.6.1.10)
_RESP2 = const(0x0A)     # RESP_FREQ(2) must be 1 on ADS1292, RLDREF_INT(1) (§8.6.1.11)

_CONFIG2_BASE = const(0x80)  # bit 7 reads/writes as 1
_PDB_REFBUF = const(0x20)    # internal reference buffer on
_VREF_4V = const(0x10)       # 4.033 V reference (needs AVDD 5 V)
_MUX_NORMAL = const(0x00)
_MUX_TEMP = const(0x04)      # internal temperature sensor, §8.3.2.4
_STATUS_MASK = const(0xF0)
_STATUS_SYNC = const(0xC0)   # frame header nibble 1100, §8.5.1.5

EXPECTED_IDS = (0x53, 0x73)  # ADS1292, ADS1292R (derived from §8.6.1.1)
FRAME_BYTES = 9              # 24 status bits + 2 x 24-bit channels

# Data rate in SPS -> CONFIG1.DR (fMOD = 128 kHz, §8.6.1.2); 8000 is noisy (§7.1)
RATES = (125, 250, 500, 1000, 2000, 4000, 8000)
# PGA gain -> CHnSET.GAIN code (§8.6.1.5)
_GAIN_CODES = {6: 0, 1: 1, 2: 2, 3: 3, 4: 4, 8: 5, 12: 6}
GAINS = (1, 2, 3, 4, 6, 8, 12)

# Ring slots: x, y, z, temperature boxcar sums, block number (continuity check)
SLOTS = const(5)
# State array indices (kept in an array so the ISR writes without allocating)
_HEAD = const(0)
_TAIL = const(1)
OVERFLOW = const(2)   # decimated samples dropped because the ring was full
FRAMES = const(3)     # DRDY edges seen (wraps at 2**30)
BADSYNC = const(4)    # frames whose status header was not 1100 (their block is discarded)
_PHASE = const(5)     # position of the next frame in its block, 0..decim-1
_SPOIL = const(6)     # 1 when the open block holds a bad frame
DISCARDED = const(7)  # blocks discarded: a bad frame, or a DRDY gap (account_gap)
BLOCKS = const(8)     # blocks completed (wraps at 2**30): the ring's sequence numbers
MISSED = const(9)     # conversions that passed unseen (polled DRDY): account_gap
_NSTATE = const(10)
MAX_WINDOW = const(64)   # window * 2**23 must stay below 2**30 (small int in the ISR)
_MASK30 = const(0x3FFFFFFF)

# Worst case waits, §2 of the fact sheet: tPOR 32 ms; RESET needs 18 tCLK
# (§8.5.1.8) or 9 fMOD cycles (§8.5.2.3): wait the longer, rounded up.
_T_POR_MS = const(40)
_T_RESET_US = const(100)
_T_REF_MS = const(100)   # internal reference settling, §8.3.6


def rate_code(rate):
    """CONFIG1.DR for a data rate; ValueError names the bad rate."""
    for i in range(len(RATES)):
        if RATES[i] == rate:
            return i
    raise ValueError("ADS1292 rate %r SPS not one of %r" % (rate, RATES))


def gain_code(gain):
    """CHnSET.GAIN for a PGA gain; ValueError names the bad gain."""
    if gain not in _GAIN_CODES:
        raise ValueError("ADS1292 gain %r not one of %r" % (gain, GAINS))
    return _GAIN_CODES[gain]


def to_signed24(b0, b1, b2):
    """24-bit two's complement (MSB first) to int, with shifts only."""
    v = (b0 << 16) | (b1 << 8) | b2
    return v - ((v & 0x800000) << 1)


class ADS1292Pair:
    """Two ADS1292 on one bus. `board` is the HAL (see hal_sim.py for the contract)."""

    def __init__(self, board, rate=2000, gains=(1, 1, 1), vref_4v=False, ring_frames=128, decim=1, window=1):
        self.board = board
        self.rate = rate
        self._dr = rate_code(rate)
        self.gains = tuple(gains)
        if len(self.gains) != 3:
            raise ValueError("need three gains (x, y, z), got %r" % (gains,))
        self._gc = [gain_code(g) for g in self.gains]
        self.vref = 4.033 if vref_4v else 2.42
        self._vref_bit = _VREF_4V if vref_4v else 0
        self.ids = [0, 0]
        # Preallocated: two frame buffers, a command buffer, the ring, counters.
        self._f0 = bytearray(FRAME_BYTES)
        self._f1 = bytearray(FRAME_BYTES)
        self._cmd = bytearray(16)
        self._rd = bytearray(16)
        # ring_frames decimated samples; 128 hold 2.56 s at 50 samples/s, ten
        # times an RP2040's ~0.2 s provisional solve (docs/firmware.md)
        self.ring_frames = ring_frames
        self.ring = array("i", bytes(4 * SLOTS * ring_frames))
        self.state = array("i", bytes(4 * _NSTATE))
        self.acc = array("i", bytes(4 * 4))   # open block: x, y, z, temperature sums
        self.set_decimation(decim, window)
        self.streaming = False
        # Bind once: creating a bound method inside an ISR allocates.
        self.isr = self._isr

    # ****** bus layer ******
    def _command(self, chip, op):
        self._cmd[0] = op
        self.board.spi_write(chip, self._cmd, 1)
        # Next command no sooner than 4 tCLK (7.8 us), §8.5.2
        self.board.sleep_us(10)

    def _wreg(self, chip, reg, value):
        c = self._cmd
        c[0] = _WREG | reg
        c[1] = 0
        c[2] = value
        self.board.spi_write(chip, c, 3)
        self.board.sleep_us(10)

    def _rreg(self, chip, reg):
        c = self._cmd
        c[0] = _RREG | reg
        c[1] = 0
        c[2] = 0
        self.board.spi_write_readinto(chip, c, self._rd, 3)
        self.board.sleep_us(10)
        return self._rd[2]

    def _set(self, chip, reg, value):
        """Write a register and read it back (§8.6: fixed bits must match)."""
        self._wreg(chip, reg, value)
        got = self._rreg(chip, reg)
        if got != value:
            raise OSError("ADS1292 #%d register 0x%02X: wrote 0x%02X, read back 0x%02X"
                          " (check MISO and the SPI mode: CPOL=0, CPHA=1)" % (chip, reg, value, got))

    # ****** API ******
    def begin(self):
        """Power-up sequence (§10.1 Fig. 72, §8.3.11 Fig. 44), probe, configure, stream."""
        b = self.board
        b.set_start(0)          # conversions only when we say so (§8.5.2.7)
        b.set_reset(1)
        b.sleep_ms(_T_POR_MS)   # tPOR = 2**12 tMOD = 32 ms after supplies settle
        b.set_reset(0)          # RESET low >= 1 tMOD resets both chips
        b.sleep_us(_T_RESET_US)
        b.set_reset(1)
        b.sleep_us(_T_RESET_US)
        b.set_spi_rate(b.REG_BAUD)  # register access: SCLK <= 2 fCLK (§8.3.7)
        for chip in (0, 1):
            self._command(chip, _SDATAC)  # chips wake in RDATAC; registers need SDATAC
            self.probe(chip)
        self.configure()
        b.sleep_ms(_T_REF_MS)
        self.start()

    def probe(self, chip):
        got = self._rreg(chip, _ID)
        self.ids[chip] = got
        if got not in EXPECTED_IDS:
            hint = "no chip answering" if got in (0x00, 0xFF) else "unexpected device"
            raise OSError("ADS1292 #%d: ID register read 0x%02X, expected 0x%02X (%s: check CS%d,"
                          " MISO/MOSI/SCLK, PWDN/RESET high, DVDD)" % (chip, got, EXPECTED_IDS[0], hint, chip))
        return got

    def configure(self):
        """CONFIG1/CONFIG2/CHnSET/RESP, each read back."""
        for chip in (0, 1):
            self._set(chip, _CONFIG1, self._dr)  # continuous conversion at the chosen rate
            self._set(chip, _CONFIG2, _CONFIG2_BASE | _PDB_REFBUF | self._vref_bit)
            self._set(chip, _RESP1, 0x02)        # §8.6.1.10: ADS1292 must be 0x02
            self._set(chip, _RESP2, 0x07)        # RESP_FREQ=1 (required), RLDREF_INT=1, bit0=1
        gx, gy, gz = self._gc
        self._set(0, _CH1SET, (gx << 4) | _MUX_NORMAL)
        self._set(0, _CH2SET, (gy << 4) | _MUX_NORMAL)
        self._set(1, _CH1SET, (gz << 4) | _MUX_NORMAL)
        # Temperature sensor: gain 1 keeps 145 mV inside full scale at any setting
        self._set(1, _CH2SET, (1 << 4) | _MUX_TEMP)

    def start(self):
        """RDATAC on both, then one START edge for both (shared pin, §8.3.9)."""
        b = self.board
        for chip in (0, 1):
            self._command(chip, _RDATAC)
        b.set_spi_rate(b.DATA_BAUD)
        self.reset_ring()
        self.streaming = True
        b.set_start(1)

    def stop(self):
        b = self.board
        b.set_start(0)
        self.streaming = False
        b.set_spi_rate(b.REG_BAUD)
        for chip in (0, 1):
            self._command(chip, _SDATAC)

    def reconfigure(self, rate=None, gains=None):
        """Change rate/gains while running: validate first, then SDATAC, write, RDATAC."""
        dr = self._dr if rate is None else rate_code(rate)
        gc = self._gc if gains is None else [gain_code(g) for g in gains]
        self.stop()
        self._dr, self._gc = dr, gc
        if rate is not None:
            self.rate = rate
        if gains is not None:
            self.gains = tuple(gains)
        self.configure()
        self.start()

    def set_decimation(self, decim, window):
        """Boxcar of the last `window` frames of every `decim` (1 <= window <= decim, window <= 64)."""
        if not (1 <= window <= decim and window <= MAX_WINDOW):
            raise ValueError("window %r must be within 1..decim (%r) and <= %d" % (window, decim, MAX_WINDOW))
        self.decim = decim
        self.window = window
        self._first = decim - window
        self.reset_ring()

    def reset_ring(self):
        st = self.state
        for i in range(_NSTATE):
            st[i] = 0
        a = self.acc
        for i in range(4):
            a[i] = 0

    def lsb_volts(self, gain):
        """Input-referred volts per code: VREF / (2**23 - 1) / gain (§8.3.8)."""
        return self.vref / 8388607 / gain

    def temperature_c(self, code):
        """Internal sensor: T = (V_uV - 145300) / 490 + 25 (§8.3.2.4 Eq. 3), gain 1."""
        uv = code * self.lsb_volts(1) * 1e6
        return (uv - 145300.0) / 490.0 + 25.0

    # ****** main loop, polled DRDY only ******
    def account_gap(self, frames):
        """`frames` conversions passed unseen (the main loop was busy; polled DRDY).

        Called by a polling HAL from the main loop, before the handler services
        the next conversion; never while `isr` can run (with a hard IRQ nothing
        is missed: the ring absorbs a stall). Advances FRAMES and the boxcar
        phase as `isr` would have, counts `frames` in MISSED, and throws away
        (DISCARDED) every block whose window lost a frame: the open block if the
        gap reaches its window, and every block that ended inside the gap. The
        block numbers still advance, so the main loop sees the gap. Integers stay
        below 2**30: `frames` is clipped to 2**29 (4.6 min at 2000 SPS).
        """
        if frames < 1:
            return
        if frames > 0x20000000:
            frames = 0x20000000
        st = self.state
        st[MISSED] = (st[MISSED] + frames) & _MASK30
        st[FRAMES] = (st[FRAMES] + frames) & _MASK30
        end = st[_PHASE] + frames   # position after the gap, from the open block's start
        ends = end // self.decim    # blocks whose last frame (always in the window) was lost
        q = end - ends * self.decim
        if ends:
            st[BLOCKS] = (st[BLOCKS] + ends) & _MASK30
            st[DISCARDED] = (st[DISCARDED] + ends) & _MASK30
            a = self.acc
            a[0] = 0
            a[1] = 0
            a[2] = 0
            a[3] = 0
            # the new open block lost its first q frames: harmless before its window
            st[_SPOIL] = 1 if q > self._first else 0
        elif end > self._first:
            st[_SPOIL] = 1          # the gap reaches into the open block's window
        st[_PHASE] = q

    # ****** interrupt path: no allocation below ******
    def _isr(self, _pin=None):
        st = self.state
        st[FRAMES] = (st[FRAMES] + 1) & _MASK30
        p = st[_PHASE]
        q = p + 1
        if q == self.decim:
            q = 0
        st[_PHASE] = q
        if p < self._first:
            return        # outside the boxcar: not read, the next conversion replaces it
        b = self.board
        f0 = self._f0
        f1 = self._f1
        b.spi_readinto(0, f0)
        b.spi_readinto(1, f1)
        a = self.acc
        if (f0[0] & _STATUS_MASK) != _STATUS_SYNC or (f1[0] & _STATUS_MASK) != _STATUS_SYNC:
            st[BADSYNC] += 1
            st[_SPOIL] = 1
        else:
            v = (f0[3] << 16) | (f0[4] << 8) | f0[5]
            a[0] += v - ((v & 0x800000) << 1)
            v = (f0[6] << 16) | (f0[7] << 8) | f0[8]
            a[1] += v - ((v & 0x800000) << 1)
            v = (f1[3] << 16) | (f1[4] << 8) | f1[5]
            a[2] += v - ((v & 0x800000) << 1)
            v = (f1[6] << 16) | (f1[7] << 8) | f1[8]
            a[3] += v - ((v & 0x800000) << 1)
        if q:
            return        # block still open
        blk = st[BLOCKS]
        st[BLOCKS] = (blk + 1) & _MASK30
        if st[_SPOIL]:
            st[_SPOIL] = 0
            st[DISCARDED] += 1
        else:
            head = st[_HEAD]
            nxt = head + 1
            if nxt == self.ring_frames:
                nxt = 0
            if nxt == st[_TAIL]:
                st[OVERFLOW] += 1
            else:
                r = self.ring
                i = head * SLOTS
                r[i] = a[0]
                r[i + 1] = a[1]
                r[i + 2] = a[2]
                r[i + 3] = a[3]
                r[i + 4] = blk
                st[_HEAD] = nxt
        a[0] = 0
        a[1] = 0
        a[2] = 0
        a[3] = 0

    # ****** main-loop side of the ring ******
    def available(self):
        """Decimated samples waiting in the ring."""
        st = self.state
        n = st[_HEAD] - st[_TAIL]
        return n + self.ring_frames if n < 0 else n

    def pop_index(self):
        """Slot index of the oldest sample, or -1; call release() when done with it."""
        st = self.state
        t = st[_TAIL]
        if t == st[_HEAD]:
            return -1
        return t * SLOTS

    def release(self):
        st = self.state
        t = st[_TAIL] + 1
        st[_TAIL] = 0 if t == self.ring_frames else t
