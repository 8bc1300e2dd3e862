"""TI ADS1292 driver: two chips on one SPI bus, one shared START line.

    acq = Acquisition(board, decim=10, window=2)
    adc = ADS1292Pair(board, acq, rate=1000, gains=(1, 1, 1))
    adc.begin()                 # reset, probe IDs, configure, verify, RDATAC, START
    board.attach_drdy(acq.isr, adc.rate, acq.account_gap)

Chip 0 digitises X (CH1) and Y (CH2); chip 1 digitises Z (CH1) and its
internal temperature sensor (CH2, MUX=0100). Section numbers refer to the
datasheet (SBAS502C); see shared/reference/ads1292-and-runtimes.md. This
module talks to the chips' registers; the frames they stream in RDATAC are
acquisition.py's (the DRDY handler, its ring and the ring's reader), which
start() resets whenever conversions (re)start.
"""

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

EXPECTED_IDS = (0x53, 0x73)  # ADS1292, ADS1292R (derived from §8.6.1.1)

# Data rate in SPS -> CONFIG1.DR (fMOD = 128 kHz, §8.6.1.2); 8000 is noisy (§7.1)
RATES = (125, 250, 500, 1000, 2000, 4000, 8000)
# PGA gain -> CHnSET.GAIN code (§8.6.1.5)
_GAIN_CODES = {6: 0, 1: 1, 2: 2, 3: 3, 4: 4, 8: 5, 12: 6}
GAINS = (1, 2, 3, 4, 6, 8, 12)

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


class ADS1292Pair:
    """Two ADS1292 on one bus. `board` is the HAL (hal.py), `acq` the
    acquisition.Acquisition that receives their frames."""

    def __init__(self, board, acq, rate=1000, gains=(1, 1, 1), vref_4v=False):
        self.board = board
        self.acq = acq
        self.rate = rate
        self._dr = rate_code(rate)
        self.gains = tuple(gains)
        if len(self.gains) != 3:
            raise ValueError("need three gains (x, y, z), got %r" % (gains,))
        self._gc = [gain_code(g) for g in self.gains]
        self.vref = 4.033 if vref_4v else 2.42
        self._vref_bit = _VREF_4V if vref_4v else 0
        self.ids = [0, 0]
        # Preallocated command buffers
        self._cmd = bytearray(16)
        self._rd = bytearray(16)
        self.streaming = False

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
        b.attach_drdy(None)     # and no handler reading frames among the register transactions (stop)
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
        self.acq.reset()
        self.streaming = True
        b.set_start(1)

    def stop(self):
        b = self.board
        b.set_start(0)
        # no DRDY handler while the registers are talked to: a conversion finishing after START
        # fell (§8.3.9) would have its frame read inside a register transaction, the handler's
        # chip select raised under it (health.py attaches the handler again once started)
        b.attach_drdy(None)
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

    def lsb_volts(self, gain):
        """Input-referred volts per code: VREF / (2**23 - 1) / gain (§8.3.8)."""
        return self.vref / 8388607 / gain

    def temperature_c(self, code):
        """Internal sensor: T = (V_uV - 145300) / 490 + 25 (§8.3.2.4 Eq. 3), gain 1."""
        uv = code * self.lsb_volts(1) * 1e6
        return (uv - 145300.0) / 490.0 + 25.0
