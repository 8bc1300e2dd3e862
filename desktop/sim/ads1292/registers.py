"""ADS1292 datasheet facts as numbers: clocks, commands, registers, rates, frames.

Everything here comes from ../shared/reference/ads1292-and-runtimes.md ([DS] = TI
datasheet SBAS502C) and is shared by the vectorised conversions (convert.py),
the byte-level chip (chip.py) and the capture files (desktop/formats/capture.py).

Time is counted in modulator ticks tMOD = 1 / 128 kHz (internal 512 kHz
oscillator, CLK_DIV=0, fMOD = fCLK / 4 [DS §8.3.7]).
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
        self.decimation = DECIMATION[min(self.dr, 6)]   # modulator ticks per conversion

    @classmethod
    def default(cls, dr=5, gain=1, mux=(MUX_NORMAL, MUX_NORMAL), vref_4v=False):
        """The configuration :func:`standard_registers` describes."""
        return cls(standard_registers(dr, gain, mux, vref_4v))

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
