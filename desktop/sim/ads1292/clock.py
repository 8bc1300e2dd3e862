"""The emulated ADS1292's oscillator and the DRDY schedule it times.

Time is counted in nominal modulator ticks tMOD = 1 / 128 kHz (internal 512 kHz
oscillator, CLK_DIV=0, fMOD = fCLK / 4 [DS §8.3.7]). The chip's own oscillator
runs at `num` / `den` times the nominal rate (1 unless the "clock-drift" fault
is on): it counts its own ticks from an anchor, and each event lands on the
first whole nominal tick at or after it, so the byte-level chip and the
vectorised convert.py agree exactly on which analog samples a conversion sees.
"""

from fractions import Fraction


class ConversionSchedule:
    """When the next conversions complete (DRDY falls), on the chip's own clock.

    Attributes
    ----------
    num, den : int
        The oscillator's frequency over the nominal one, num / den.
    anchor : int
        Nominal tick from which the schedule counts own ticks.
    m_next : int or None
        Own ticks from `anchor` to the next DRDY (None: none scheduled).
    next_drdy : int or None
        Nominal tick of the next DRDY (None: none scheduled).
    """

    def __init__(self):
        self.num = self.den = 1
        self.anchor = 0
        self.m_next = None
        self.next_drdy = None

    @property
    def ratio(self):
        """The oscillator's frequency over the nominal 512 kHz."""
        return self.num / self.den

    @property
    def drifting(self):
        return self.num != self.den

    def set_ratio(self, ratio):
        """Run the oscillator at `ratio` (a Fraction) of the nominal frequency. A new clock
        takes effect after the conversion in progress: the pending DRDY keeps its tick,
        the ones after it follow the new clock."""
        ratio = Fraction(ratio)
        if (ratio.numerator, ratio.denominator) != (self.num, self.den):
            if self.m_next is not None:        # re-anchor at the pending DRDY, which stays put
                self.anchor, self.m_next = self.next_drdy, 0
            self.num, self.den = ratio.numerator, ratio.denominator

    def nominal_tick(self, m):
        """Nominal tick of own tick `m` (an int or an int64 array) counted from the anchor:
        the first nominal tick at or after it (events land on whole ticks)."""
        if self.num == self.den:
            return self.anchor + m
        return self.anchor - ((-m * self.den) // self.num)

    def start(self, tick, own_ticks):
        """Count from nominal tick `tick`: the first DRDY comes `own_ticks` of the chip's
        own clock later."""
        self.anchor, self.m_next = tick, own_ticks
        self.next_drdy = self.nominal_tick(own_ticks)

    def stop(self):
        """No DRDY scheduled."""
        self.m_next = self.next_drdy = None

    def due_by(self, tick, decimation):
        """How many conversions, the next one first and `decimation` own ticks apart,
        complete at a nominal tick <= `tick` (< 1 if none)."""
        return (((tick - self.anchor) * self.num) // self.den - self.m_next) // decimation + 1

    def complete(self, n, decimation):
        """The next `n` conversions complete: schedule the one after them and return the
        nominal tick of the last of them."""
        m_last = self.m_next + (n - 1) * decimation
        self.m_next = m_last + decimation
        self.next_drdy = self.nominal_tick(self.m_next)
        return self.nominal_tick(m_last)
