"""The simulated world on the emulated Pico's pins: the Python end of desktop/devicesim/pico/pins.mjs.

    world, operator = live_world()                      # desktop/devicesim/virtual_handheld.py
    pins = PinWorld(world, hands)
    PicoBoard(flash, world=pins)                         # serves it on a thread of its own

The two ADS1292 are desktop/sim's byte-level model inside world.World (the same World the other
runtimes use); the runner sends what the firmware does on the pins and the SPI bus, with the
emulated time of each (ns since the chip's power-on), and this moves the World to that time
first: the world's clock is the emulated clock. pins.mjs says why frames are handed ahead: a
frame read is answered there from the frame sent here with the last reply and clocked through
the model afterwards ('R'); a byte the model answered differently is counted in `mismatches`.
Chip 0's DRDY falls until the runner's next news are handed ahead too (the schedule: no world
state in them), so the runner asks only at news, at a read of a new conversion's frame, and at
what the firmware does to the chips, not at every conversion.
"""

import math
import struct

from desktop.devicesim import world as world_module
from desktop.sim.ads1292.faults import DRDY_DEAD
from desktop.sim.ads1292.registers import F_MOD

MSG = struct.Struct("<BBHxxxxd")          # type, a, b, emulated ns
FALLS = 16                                # DRDY falls handed ahead in one reply, at most
# miso, flags, next event ns, frames' valid-until ns, frames, falls listed, their ns
REPLY = struct.Struct("<BB6xddd9s9sB7x%dd" % FALLS)
START, RESET, LED = 22, 26, 25            # device/config.py's pin_start, pin_reset, pin_led
DRDY_LOW, DRDY_FELL, PRESSED = 1, 2, 4
# the runner asks for news at least this often: the button and the operator's LED-following
# are seen within it (a person's press lasts 100 ms or more)
NEWS_S = 0.010


class PinWorld:
    def __init__(self, world, hands=None):
        self.world = world
        self.hands = hands
        self.offset = world.time          # world time (s) at emulated time 0
        self._falls = world.chips[0].drdy_falls
        self._frames = [b"", b""]         # what the runner holds for each chip
        self._listed = []                 # emulated ns of the falls the last reply handed ahead
        self._at_ns = 0                   # emulated ns of the message in hand
        self.counts = {"B": 0, "T": 0, "S": 0, "R": 0, "E": 0, "P": 0}
        self.replayed = 0                 # frame bytes answered in the runner and clocked through here
        self.mismatches = 0               # ... of which the model answered otherwise
        self.boots = 0

    # ****** time ******
    def _to(self, ns):
        """Move the world to emulated time `ns` (never back: a transfer moves the chips itself)."""
        t = self.offset + ns * 1e-9
        if t > self.world.time:
            self.world.sleep_us((t - self.world.time) * 1e6)

    def _ns(self, t):
        # rounded up, and a tick past: the world reached from it is at or after t
        return math.ceil((t - self.offset) * 1e9) + 1

    def _select(self, mask):
        for i, chip in enumerate(self.world.chips):
            chip.select(bool(mask >> i & 1))

    # ****** the messages ******
    def handle(self, kind, a, b, ns):
        """One message from the runner; the reply bytes, or None for none."""
        self.counts[kind] += 1
        self._at_ns = ns
        w = self.world
        if kind == "B":                   # the chip (re)starts: its clock starts at 0
            self.offset = w.time
            self.boots += 1
            self._listed = []
            self._select(0)
            return None
        self._to(ns)
        if kind == "T":
            if self.hands is not None:
                self.hands.step()
            return self._reply(0)
        if kind == "S":
            self._select(a)
            return self._reply(w.bus.transfer(bytes((b,)))[0])
        if kind == "R":                   # frame bytes the runner answered: the model clocks them too
            self._select(a)
            got = w.bus.transfer(bytes(b))
            k = a.bit_length() - 1
            want = (self._frames[k] * (b // 9 + 1))[:b]
            self.replayed += b
            self.mismatches += got != want
            return None
        if kind == "E":
            self._select(0)
            return None
        if kind == "P":
            which = {START: world_module.wire.PIN_START, RESET: world_module.wire.PIN_RESET,
                     LED: world_module.wire.PIN_LED}[a]
            w.pin(which, b)
            return None if a == LED else self._reply(0)
        raise ValueError("bad message %r from the Pico runner" % kind)

    def _reply(self, miso):
        w = self.world
        c0 = w.chips[0]
        flags = 0 if c0.drdy else DRDY_LOW
        now = w.time
        # a conversion since the last reply that the runner did not make an edge for itself
        # (the falls handed ahead): an edge on the pin now
        if c0.drdy_falls - self._falls > sum(1 for t in self._listed if t <= self._at_ns):
            flags |= DRDY_FELL
        self._falls = c0.drdy_falls
        if any(down <= now < up for down, up in w.button_events):
            flags |= PRESSED
        news = [now + NEWS_S] + [e for ev in w.button_events for e in ev if e > now]
        falls = _falls_ahead(c0, w.start_level)
        if len(falls) > FALLS:            # more than a reply holds: news at the first not held
            news.append(falls[FALLS])
        news_at = min(news)
        # as the runner's alarms fire them: it has made the edge by the time of any later request
        self._listed = [self._ns(t) for t in falls[:FALLS] if t < news_at]
        frames, valid = [], []
        for k, chip in enumerate(w.chips[:2]):
            nxt = _next_conversion(chip)
            ok = chip.rdatac and not chip.selected and chip.fault is None
            frames.append(chip.frame if ok else bytes(9))
            valid.append((self._ns(nxt) - 2 if nxt is not None else 1e300) if ok else -1.0)
        self._frames = frames
        listed = self._listed + [0.0] * (FALLS - len(self._listed))
        return REPLY.pack(miso, flags, self._ns(news_at), valid[0], valid[1], frames[0], frames[1], len(self._listed),
                          *listed)

    def serve(self, read, write):
        """Answer the runner until its pipe ends: read(n) -> bytes (b"" at the end), write(bytes)."""
        while True:
            m = read(MSG.size)
            if len(m) < MSG.size:
                return
            kind, a, b, ns = MSG.unpack(m)
            reply = self.handle(chr(kind), a, b, ns)
            if reply is not None:
                write(reply)


def _falls_ahead(chip, start_level):
    """Chip times (s) of the chip's next DRDY edges within NEWS_S, FALLS + 1 at most: the
    schedule's, which nothing but a request (START, a command) or news (a fault) changes. With
    START low or the chip stopping, the next one only."""
    first = _next_conversion(chip)
    if first is None:
        return []
    if not start_level or chip.stopping:
        return [first]
    s = chip.schedule
    step = chip.config.decimation
    out = []
    m = s.m_next
    while len(out) <= FALLS:
        t = s.nominal_tick(m) / F_MOD
        if t > first + NEWS_S:
            break
        out.append(t)
        m += step
    return out


def _next_conversion(chip):
    """Chip time (s) of the chip's next DRDY edge, or None (stopped, standby, a dead DRDY)."""
    tick = chip.schedule.next_drdy
    if tick is None or chip.standby or chip.fault in DRDY_DEAD:
        return None
    return tick / F_MOD
