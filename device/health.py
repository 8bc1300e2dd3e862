"""ADC health at run time, from the acquisition's counters: named faults, and when to re-probe.

    health = Health(acq, rate)
    problem = health.check(now_ms, diff)   # None, or (code, message) once a fault shows
    health.restart(now_ms)                 # conversions (re)started: judge afresh

The DRDY handler counts every conversion (FRAMES) and every frame whose status
header is not 1100 (BADSYNC) [DS 8.5.1.5]; this module looks at them a few times
a second, so a chip that dies after boot is named instead of the data just stopping:
- adc_no_drdy: no conversion for 20 periods (at least 100 ms): DRDY stuck high or
  low, START low, the clock or the supply gone. (A polling HAL services a DRDY
  stuck low on every poll: there the frames it reads tell, below.)
- adc_silent / adc_all_ones / adc_bad_headers: at least half the frames read in
  the last period had a bad header; the last bad byte names it: 0x00 (the chip
  does not drive MISO: unpowered, CS open), 0xFF (MISO stuck high), else noise.
The app then stops the survey output and calibration and re-probes the chips
every REPROBE_MS (reset, ID, registers, RDATAC: ads1292.py begin); the
interval doubles, up to 60 s, each time a fault comes back within a minute of
clearing, so a flaky chip is not reset twice a second.
"""

from acquisition import BADSYNC, BLOCKS, FRAMES, LASTBAD

CHECK_MS = 250
REPROBE_MS = 2000
REPROBE_MAX_MS = 60000


class Health:
    def __init__(self, acq, rate, now):
        self.acq = acq
        self.reprobe_ms = REPROBE_MS
        self.faults = 0          # faults seen since boot
        self.cleared_at = None   # when the last fault cleared
        self.rate_changed(rate, now)

    def rate_changed(self, rate, now):
        self.deadline_ms = max(100, 20000 // rate)
        self.window = self.acq.window
        self.restart(now)

    def restart(self, now):
        st = self.acq.state
        self._t = now
        self._seen = now         # last time FRAMES moved
        self._frames = st[FRAMES]
        self._blocks = st[BLOCKS]
        self._bad = st[BADSYNC]
        self.flowing = False     # conversions came, with good headers, in the last check period

    def check(self, now, diff):
        if diff(now, self._t) < CHECK_MS:
            return None
        st = self.acq.state
        frames = st[FRAMES]
        blocks = st[BLOCKS]
        bad = st[BADSYNC]
        read = (blocks - self._blocks) * self.window   # frames read in the boxcars (wraps: < 0, skip)
        nbad = bad - self._bad
        self._t = now
        self.flowing = frames != self._frames
        if self.flowing:
            self._seen = now
        self._frames = frames
        self._blocks = blocks
        self._bad = bad
        if diff(now, self._seen) >= self.deadline_ms:
            return "adc_no_drdy", ("no conversion for %d ms: DRDY stuck or the ADC stopped"
                                   " (check DRDY, START, the clock, AVDD/DVDD)" % diff(now, self._seen))
        if read >= 4 and 2 * nbad >= read:
            self.flowing = False
            v = st[LASTBAD]
            chip = v >> 8
            byte = v & 0xFF
            if byte == 0x00:
                return "adc_silent", ("ADS1292 #%d stopped answering (frames read 0x00: check its CS,"
                                      " power and MISO)" % chip)
            if byte == 0xFF:
                return "adc_all_ones", "the SPI bus reads all ones from ADS1292 #%d (MISO stuck high?)" % chip
            return "adc_bad_headers", ("%d of %d frames from ADS1292 #%d had a bad header (0x%02X):"
                                       " noise or a loose SPI line" % (nbad, read, chip, byte))
        return None

    def fault_seen(self, now, diff):
        """A fault began: a fault that comes back soon after clearing doubles the re-probe interval."""
        self.faults += 1
        if self.cleared_at is not None and diff(now, self.cleared_at) < 60000:
            self.reprobe_ms = min(REPROBE_MAX_MS, 2 * self.reprobe_ms)

    def cleared(self, now):
        self.cleared_at = now
