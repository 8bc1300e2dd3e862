"""The simulated handheld around the firmware: two emulated ADS1292 fed by the
simulator's world (sensor, field, operator), the button, the LED and the USB
serial line (a real pseudo-terminal).

    w = make_world(serial="pty", motion="hand", seconds=60, seed=1)   # Scenario settings
    w.until = 10.0                       # run budget (s of simulated time)
    w.press(hold_s=0.2)                  # the operator's thumb, from now
    w.serial_port                        # path pyserial can open

The firmware's sim HAL (device/sim/hal_sim.py) talks to a World through a link:
in-process, World itself is the link object (the methods sim_link.PipeLink
has); for the `micropython` executable, link_host.py decodes the pipe messages
and calls the same methods. Simulated time advances only here, in `idle` and
`sleep_us`, so a run is deterministic whatever the host's speed.
"""

import os
import select
import time
import tty

from desktop.firmware.files import import_device
from desktop.sim.ads1292.registers import F_MOD
from desktop.sim.handheld import Handheld
from desktop.sim.scenario import Scenario

wire = import_device("sim_wire")

BATCH = 512   # conversions each chip computes per vectorised call (ADS1292 `batch`)
SYSTICK_S = 0.001   # a core in idle wakes at the latest on its 1 ms tick (or any interrupt)
HOST_POLL_S = 0.002  # the pty is polled for the host's bytes every this much simulated time (USB: 1 ms frames)


def make_world(serial="pty", fault=(None, None), chip_ids=(0x53, 0x53), t0=0.1, chunked=False, **scenario):
    """A World on the simulator's Handheld for the given Scenario settings
    (desktop/sim/scenario.py: sensor, motion, seconds, seed, rate, dipole, ...); chunked:
    the analog input computed as time goes (hours of simulated time, Handheld `chunked`)."""
    return World(Handheld(Scenario(**scenario), t0=t0, fault=fault, chip_ids=chip_ids, chunked=chunked),
                 serial=serial)


class World:
    def __init__(self, handheld, serial="pty"):
        self.handheld = handheld
        self.scenario = handheld.scenario
        self.chips = handheld.chips
        for c in self.chips:
            c.batch = BATCH
        self.bus = handheld.bus
        self._c0, self._others = self.chips[0], self.chips[1:]
        self._next_host_poll = self._tx_blocked_until = 0.0
        self.t_us = 0
        self.flags = 0
        self.pending = 0
        self.until = 0.0
        self.quit = False
        self.on_due = None          # called by idle() once the run's time is up (runners.InProcessDevice)
        self._falls = 0
        self.drdy_edges = 0         # DRDY edges of chip 0 delivered to the firmware (F_DRDY replies)
        self.drdy_merged = 0        # conversions whose edge fell in the same wait as another (lost to an IRQ)
        self.button_events = []     # (t_down, t_up) seconds
        self.led_log = []           # (t, level)
        self.start_level = False
        self.out = bytearray()      # everything the firmware wrote to serial
        self.to_host = 0            # bytes written into the pty (the host can read this many)
        self.from_host = 0          # bytes read from the pty
        self._rx = bytearray()      # bytes from the host not yet read by the firmware
        self._tx = bytearray()      # bytes not yet accepted by the pty
        self.xfers = 0
        self.idles = 0
        self.stalls = []            # (t, seconds, chip 0 conversions) at each charged main-loop stall
        self.master = self.slave = None
        self.serial_port = None
        if serial == "pty":
            self.master, self.slave = os.openpty()
            tty.setraw(self.slave)  # no echo, no line discipline: a plain byte pipe like USB CDC
            os.set_blocking(self.master, False)
            self.serial_port = os.ttyname(self.slave)

    # ****** time and the analog inputs ******
    @property
    def time(self):
        return self.chips[0].time

    def _advance(self, seconds):
        self._ahead(seconds)
        self._sync()
        self.bus.advance(seconds)

    def _sync(self):
        """Bring the other chips to chip 0's time. Waiting for DRDY moves chip 0 only (its
        DRDY is the one wired to the MCU): the others catch up here, in one step, before
        anything reaches the bus or the pins (their conversions are the same either way)."""
        tick = self._c0.tick
        for c in self._others:
            if c.tick < tick:
                c.advance_to_tick(tick)

    def _ahead(self, seconds):
        """A live or chunked handheld computes its analog input as time goes (desktop/sim/handheld.py)."""
        t = self.time + seconds
        if t > self.handheld.ahead_until:
            self._sync()            # the chips hold the old window until they are past it
            self.handheld.keep_ahead(t)

    def _sync_time(self):
        self.t_us = int(round(self.time * 1e6)) & wire.T_MASK

    def _button_level(self):
        t = self.time
        for down, up in self.button_events:
            if down <= t < up:
                return True
        return False

    def _next_event(self, t):
        nxt = self.until
        for down, up in self.button_events:
            for e in (down, up):
                if t < e < nxt:
                    nxt = e
        return nxt

    # ****** scripted operator ******
    def press(self, hold_s=0.2, at=None):
        t = self.time if at is None else at
        self.button_events.append((t, t + hold_s))

    # ****** link methods (sim_link.PipeLink's, in-process) ******
    def xfer(self, chip, wbuf, rbuf, n):
        """One SPI transaction: CS of `chip` low (every CS high for wire.NO_CHIP), n bytes, CS high."""
        data = bytes(n) if wbuf is None else bytes(wbuf[:n])
        self._sync()
        self.bus.select(None if chip == wire.NO_CHIP else chip)
        rx = self.bus.transfer(data)
        self.bus.select(None)
        self.xfers += 1
        if rbuf is not None:
            rbuf[:n] = rx
        self._sync_time()
        return rx

    def pin(self, which, value):
        self._sync()
        if which == wire.PIN_START:
            self.start_level = bool(value)
            self.bus.start = bool(value)
        elif which == wire.PIN_RESET:
            for c in self.chips:
                c.pwdn_reset(bool(value))
        elif which == wire.PIN_LED:
            self.led_log.append((self.time, value))

    def set_baud(self, hz):
        for c in self.chips:
            c.sclk_hz = float(hz)

    def sleep_us(self, us):
        self._advance(us / 1e6)
        self._sync_time()

    def idle(self, max_us=0, advance=True):
        """Advance to the next DRDY edge of chip 0 (or the next scripted event, or the budget),
        at most SYSTICK_S: a core waiting for an interrupt wakes on its 1 ms tick, so a DRDY
        that never comes (a dead chip, ads1292/faults.py) does not stop the main loop.

        max_us > 0: a charged main-loop stall in IRQ mode (hal_sim.Board.busy):
        return at the next DRDY or after max_us, whatever the run budget says,
        since the firmware is busy and sees neither the button nor the budget.
        """
        if advance and not max_us and self.on_due is not None and self.time >= self.until and not self.quit:
            self.on_due()           # the run's time is up: the runner parks the firmware here
        self.idles += 1
        t = self.time
        limit = min(t + max_us / 1e6 if max_us else self._next_event(t), t + SYSTICK_S)
        flags = 0
        if advance and limit > t:
            c0 = self._c0
            if self.start_level and c0.schedule.next_drdy is not None:
                self._ahead(limit - t)
                try:        # DRDY of chip 0 is wired to the MCU; the others follow in _sync
                    c0.advance_to_tick(c0.next_drdy_tick(limit - t))
                except TimeoutError:
                    pass
            else:
                self._advance(limit - t)
        falls = self.chips[0].drdy_falls
        if falls != self._falls:   # edge-triggered, like Pin.irq(IRQ_FALLING)
            self.drdy_edges += 1
            self.drdy_merged += falls - self._falls - 1
            self._falls = falls
            flags |= wire.F_DRDY
        if not self.chips[0].drdy:
            flags |= wire.F_DRDY_LOW
        if self.button_events and self._button_level():
            flags |= wire.F_BUTTON
        self._pump_serial()
        if self._rx:
            flags |= wire.F_SERIAL
        if self.quit:
            flags |= wire.F_QUIT
        self.flags = flags
        self.pending = min(len(self._rx), 0xFFFF)
        self._sync_time()

    def poll(self, max_us):
        """A pin read that takes time (OP_POLL): nothing passes while chip 0's DRDY is low,
        else time runs until it falls or max_us passed."""
        self._sync()
        if self.chips[0].drdy and self.start_level:
            self._ahead(max_us / 1e6)
            try:
                self.bus.wait_drdy(0, timeout=max_us / 1e6)
            except TimeoutError:
                pass
        elif self.chips[0].drdy:
            self._advance(max_us / 1e6)
        self.idle(0, advance=False)

    def stall(self, us, advance):
        """A charged main-loop stall starts (hal_sim.Board.busy); advance: polled, let it pass."""
        self.stalls.append((self.time, us / 1e6, self.chips[0].conversions))
        if advance:
            self.sleep_us(us)

    def serial_read(self):
        data = bytes(self._rx)
        self._rx = bytearray()
        return data

    def serial_write(self, data):
        self.out += data
        self._tx += data
        self._pump_serial()

    # ****** the serial line ******
    def send(self, data):
        """Bytes to the firmware without a pty (in-memory serial)."""
        self._rx += data

    def _pump_serial(self):
        if self.master is None:
            self._tx = bytearray()
            return
        t = self._c0.tick / F_MOD
        if self._tx and t >= self._tx_blocked_until:
            try:
                n = os.write(self.master, self._tx)
                del self._tx[:n]
                self.to_host += n
            except BlockingIOError:     # the pty is full (the host reads slowly): try again later
                self._tx_blocked_until = t + HOST_POLL_S
        if t >= self._next_host_poll:
            self._next_host_poll = t + HOST_POLL_S
            self._read_host(0)

    def _read_host(self, timeout):
        r, _, _ = select.select([self.master], [], [], timeout)
        if r:
            try:
                data = os.read(self.master, 65536)
            except (BlockingIOError, OSError):
                return
            self._rx += data
            self.from_host += len(data)

    def receive(self, total, timeout=2.0):
        """Wait (wall time) until `total` bytes from the host have crossed the pty.

        A pty hands bytes over asynchronously; simulated time runs far faster
        than that, so a client makes sure its request has arrived before it
        lets the firmware run (the firmware's thread is parked meanwhile).
        """
        end = time.monotonic() + timeout
        while self.master is not None and self.from_host < total and time.monotonic() < end:
            self._read_host(0.01)

    def lines(self):
        """Everything the firmware printed, as text lines."""
        return self.out.decode(errors="replace").splitlines()

    def close(self):
        for fd in (self.master, self.slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self.master = self.slave = None
