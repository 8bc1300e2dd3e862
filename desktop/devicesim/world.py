"""The simulated handheld around the firmware: two emulated ADS1292, the analog
world, the button, the LED and the USB serial line (a real pseudo-terminal).

The firmware's sim HAL (device/hal_sim.py) talks to a World through a link:
in-process, World itself is the link object (same methods as hal_sim.PipeLink);
for the `micropython` executable, desktop/devicesim/runner.py decodes the pipe
messages and calls the same methods. Simulated time advances only here, in
`idle` and `sleep_us`, so a run is deterministic whatever the host's speed.

    w = World(analog, rate_hint=2000, serial="pty")
    w.until = 10.0                       # run budget (s of simulated time)
    w.press(hold_s=0.2)                  # the operator's thumb, from now
    w.serial_port                        # path pyserial can open
"""

import os
import select
import tty

import numpy as np

from desktop.sim.ads1292 import ADS1292, SPIBus

BATCH = 512   # conversions each chip computes per vectorised call (ADS1292 `batch`)

GRID_HZ = 16000
CHUNK_S = 0.5
_T_MASK = 0x3FFFFFFF

F_DRDY, F_BUTTON, F_SERIAL, F_QUIT = 1, 2, 4, 8


class World:
    def __init__(self, analog=None, seed=0, serial="pty", chip_ids=(0x53, 0x53), faults=(None, None),
                 handheld=None):
        self.analog = analog
        self.handheld = handheld
        if handheld is not None:
            # desktop.sim.board.Handheld: the simulator's full analog chain, preloaded
            self.chips = handheld.chips
            for c in self.chips:
                c.batch = BATCH
            self._loaded_to = float("inf")
        else:
            self.chips = [ADS1292(chip_ids[i], seed=seed + 17 * i, fault=faults[i], batch=BATCH) for i in range(2)]
            self._loaded_to = -1.0
        self.bus = SPIBus(self.chips)
        self.t_us = 0
        self.flags = 0
        self.pending = 0
        self.until = 0.0
        self.quit = False
        self._falls = 0
        self.button_events = []     # (t_down, t_up) seconds
        self.led_log = []           # (t, level)
        self.start_level = False
        self.host_log = []
        self.out = bytearray()      # everything the firmware wrote to serial
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

    def _ensure(self, t_end):
        """Load analog chunks so the chips have inputs up to t_end (with look-back)."""
        if self._loaded_to >= t_end:
            return
        now = self.time
        # The grid starts 30 ms before now: conversions not yet computed look back
        # over the sinc3 window, 3/fDR (24 ms at 125 SPS).
        g0 = max(0.0, np.floor((now - 0.03) * GRID_HZ) / GRID_HZ)
        end = max(t_end, now + CHUNK_S)
        n = int(np.ceil((end - g0) * GRID_HZ)) + 1
        t = g0 + np.arange(n) / GRID_HZ
        v0, v1 = self.analog.volts(t)
        self.chips[0].load(v0, GRID_HZ, g0, self.analog.temperature_c)
        self.chips[1].load(v1, GRID_HZ, g0, self.analog.temperature_c)
        self._loaded_to = g0 + (n - 1) / GRID_HZ

    def _advance(self, seconds):
        self._ensure(self.time + seconds + 0.001)
        self.bus.advance(seconds)

    def _sync_time(self):
        self.t_us = int(round(self.time * 1e6)) & _T_MASK

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

    # ****** link methods (hal_sim.PipeLink's, in-process) ******
    def xfer(self, chip, wbuf, rbuf, n):
        data = bytes(n) if wbuf is None else bytes(wbuf[:n])
        self._ensure(self.time + 0.001)
        self.bus.select(chip)
        rx = self.bus.transfer(data)
        self.bus.select(None)
        self.xfers += 1
        if rbuf is not None:
            rbuf[:n] = rx
        self._sync_time()
        return rx

    def pin(self, which, value):
        if which == 0:
            self.start_level = bool(value)
            self.bus.start = bool(value)
        elif which == 1:
            for c in self.chips:
                c.pwdn_reset(bool(value))
        elif which == 2:
            self.led_log.append((self.time, value))

    def set_baud(self, hz):
        for c in self.chips:
            c.sclk_hz = float(hz)

    def sleep_us(self, us):
        self._advance(us / 1e6)
        self._sync_time()

    def idle(self, max_us=0):
        """Advance to the next DRDY edge of chip 0 (or the next scripted event, or the budget).

        max_us > 0: a charged main-loop stall in IRQ mode (hal_sim.Board.busy):
        return at the next DRDY or after max_us, whatever the run budget says,
        since the firmware is busy and sees neither the button nor the budget.
        """
        self.idles += 1
        t = self.time
        limit = t + max_us / 1e6 if max_us else self._next_event(t)
        flags = 0
        if limit > t:
            c0 = self.chips[0]
            if self.start_level and c0._next_drdy is not None:
                self._ensure(t + (c0._next_drdy - c0.tick) / 128000.0 + 0.001)
                try:
                    self.bus.wait_drdy(0, timeout=limit - t)   # DRDY of chip 0 is wired to the MCU
                except TimeoutError:
                    pass
            else:
                self._advance(min(0.001, limit - t))
        falls = self.chips[0].drdy_falls
        if falls != self._falls:   # edge-triggered, like Pin.irq(IRQ_FALLING)
            self._falls = falls
            flags |= F_DRDY
        if self._button_level():
            flags |= F_BUTTON
        self._pump_serial()
        if self._rx:
            flags |= F_SERIAL
        if self.quit:
            flags |= F_QUIT
        self.flags = flags
        self.pending = min(len(self._rx), 0xFFFF)
        self._sync_time()

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

    def log(self, text):
        self.host_log.append(text)

    # ****** the serial line ******
    def send(self, data):
        """Bytes to the firmware without a pty (in-memory serial)."""
        self._rx += data

    def _pump_serial(self):
        if self.master is None:
            self._tx = bytearray()
            return
        if self._tx:
            try:
                n = os.write(self.master, self._tx)
                del self._tx[:n]
            except BlockingIOError:
                pass
        r, _, _ = select.select([self.master], [], [], 0)
        if r:
            try:
                self._rx += os.read(self.master, 65536)
            except (BlockingIOError, OSError):
                pass

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
