"""ADC health at run time: named faults from the acquisition's counters, and the chips' supervisor.

    health = Health(acq, rate, now_ms)
    problem = health.check(now_ms, diff)   # None, or (code, message) once a fault shows
    health.restart(now_ms)                 # conversions (re)started: judge afresh

    sup = AdcSupervisor(board, proto, led, acq)   # app.py wires it
    sup.start(cfg)             # probe and start the chips (or reconfigure running ones)
    sup.check(now_ms)          # every main-loop pass: a fault named, a re-probe due, a fault cleared
    sup.status()               # its part of `status`

The DRDY handler counts every conversion (FRAMES) and every frame whose status
header is not 1100 (BADSYNC) [DS 8.5.1.5]; this module looks at them a few times
a second, so a chip that dies after boot is named instead of the data just stopping:
- adc_no_drdy: no conversion for 20 periods (at least 100 ms): DRDY stuck high or
  low, START low, the clock or the supply gone. (A polling HAL services a DRDY
  stuck low on every poll: there the frames it reads tell, below.)
- adc_silent / adc_all_ones / adc_bad_headers: at least half the frames read in
  the last period had a bad header; the last bad byte names it: 0x00 (the chip
  does not drive MISO: unpowered, CS open), 0xFF (MISO stuck high), else noise.
A chip that does not answer its probe (at boot or at a re-probe) is adc_probe.
The supervisor then stops the survey output and calibration (the fault event, the
FAULT LED, a calibration in progress ends with reason "fault") and re-probes the
chips every REPROBE_MS (reset, ID, registers, RDATAC: ads1292.py begin); the
interval doubles, up to 60 s, each time a fault comes back within a minute of
clearing, so a flaky chip is not reset twice a second. A chip that answers again
is cleared once conversions flow healthy for a check period, not on its registers
alone (a stuck DRDY passes a probe).
"""

import led as ledp
from acquisition import BADSYNC, BLOCKS, FRAMES, LASTBAD
from ads1292 import ADS1292Pair
from shared import codes

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
        # every main-loop pass; the check itself a method of its own, so that this frame stays
        # within the 11 words MicroPython keeps off the heap (app.py, Frames)
        return None if diff(now, self._t) < CHECK_MS else self._check(now, diff)

    def _check(self, now, diff):
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


class AdcSupervisor:
    """The ADS1292 pair's life in the app: started, watched (Health), faulted, re-probed, cleared.

    flow (a fault ends its session) and on_cleared (the app sets its pipeline up
    again) are wired by app.py."""

    def __init__(self, board, proto, led, acq):
        self.board = board
        self.proto = proto
        self.led = led
        self.acq = acq
        self.cfg = None
        self.adc = None            # the ADS1292Pair, once started
        self.health = None         # once the chips answered
        self.fault = None          # the fault's message (None: healthy)
        self.fault_code = None
        self.verifying = False     # re-probed: conversions flow, not yet judged healthy
        self.flow = None
        self.on_cleared = None
        self._last_code = None
        self._reprobe_at = None

    def start(self, cfg, reprobe=False):
        """Probe and start the chips (a re-probe resets them first), or reconfigure running ones."""
        self.cfg = cfg
        gains = (cfg["gain_x"], cfg["gain_y"], cfg["gain_z"])
        try:
            if self.adc is None:
                self.adc = ADS1292Pair(self.board, self.acq, cfg["rate"], gains, cfg["vref_4v"])
                self.adc.begin()
            elif reprobe:
                self.adc.begin()
            else:
                self.adc.reconfigure(cfg["rate"], gains)
            # again after a reconfigure: a polling HAL restarts its gap clock at the new rate
            self.board.attach_drdy(self.acq.isr, self.adc.rate, self.acq.account_gap)
            now = self.board.ticks_ms()
            if self.health is None:
                self.health = Health(self.acq, self.adc.rate, now)
            else:
                self.health.rate_changed(self.adc.rate, now)
            # a chip that failed answers again: it is cleared once conversions flow healthy
            # for a check period (Health), not on its registers alone (a stuck DRDY
            # passes a probe)
            self.verifying = self.fault is not None
        except OSError as e:
            self.verifying = False
            self.set_fault("adc_probe", str(e))

    def rate_changed(self, rate, now):
        if self.health is not None:
            self.health.rate_changed(rate, now)

    def set_fault(self, code, msg):
        b = self.board
        now = b.ticks_ms()
        first = self.fault is None
        self.fault = msg
        self.fault_code = code
        if self.health is not None and first:
            self.health.fault_seen(now, b.ticks_diff)
        self._reprobe_at = now
        self.led.set(ledp.FAULT)
        if first or code != self._last_code:
            self.proto.event("fault", {"code": code, "msg": msg})
        self._last_code = code
        self.flow.abort(codes.FAULT, msg, False)

    def check(self, now):
        """Health of a running ADC; re-probe a faulty one every health.reprobe_ms."""
        b = self.board
        if self.fault and not self.verifying:
            ms = self.health.reprobe_ms if self.health is not None else REPROBE_MS
            if self._reprobe_at is None or b.ticks_diff(now, self._reprobe_at) >= ms:
                self._reprobe_at = now
                self.start(self.cfg, reprobe=True)
            return
        if self.health is None:
            return
        problem = self.health.check(now, b.ticks_diff)
        if problem is not None:
            self.verifying = False
            self.set_fault(problem[0], problem[1])
        elif self.verifying and self.health.flowing:
            self.verifying = False
            self.health.cleared(now)
            self.proto.event("fault", {"code": None, "cleared": self.fault_code})
            self.fault = None
            self.fault_code = None
            self._reprobe_at = None
            self.on_cleared()

    def status(self):
        """Its part of `status`: the fault, the acquisition's counters, the faults since boot."""
        out = {"fault": self.fault, "fault_code": self.fault_code}
        if self.adc is not None:
            out.update(self.acq.status())
            if self.health is not None:
                out["adc_faults"] = self.health.faults
        return out
