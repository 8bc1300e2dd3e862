# MicroPython module for the bench scripts (firmware_cost.py, firmware_heap.py, cortexm_firmware.py; not
# a module of the desktop package): a loop-back board that runs the firmware's App on real frames without
# the simulator, and the App's parts those scripts drive (parts, start_cal, finish_cal).
# Register access is answered from a 12-byte register file per chip; each DRDY edge reads the next
# frame (2 x 9 bytes: status, CH1, CH2 as the two ADS1292 send them) from `src`, any object with
# seek(pos) and readinto(buf): io.BytesIO over a table in RAM, or a file opened "rb" (the table then
# stays out of the heap, e.g. on a ROM filesystem). The table wraps around at its end.
# Only what every MicroPython port has: no time, os or /proc here (the unix-only timing stays in
# the scripts), so it also runs bare-metal. The DRDY handler runs with the heap locked, as in a
# hard interrupt: an allocation there fails here as it would on a board.

from micropython import heap_lock, heap_unlock

FRAME = 9     # bytes per chip per conversion


class LoopBoard:
    REG_BAUD = 1000000
    DATA_BAUD = 8000000
    sleeps_with_irq = False   # idle() runs the handler itself: App.wait counts conversions, as in the simulator
    polls_drdy = False        # but misses none: every conversion is read, as an interrupt would (hal.py)

    def __init__(self, src, root, rate):
        self.nf = src.seek(0, 2) // (2 * FRAME)
        src.seek(0)
        self.src = src
        self._seek = src.seek
        self._readinto = src.readinto
        self._cs = (abs, abs)   # stands in for the CS Pin calls of hal_micropython
        self.k = 0
        self.root = root
        self.name = "bench-loopback"
        self.regs = [bytearray(b"\x53\x02\x80\x10\x00\x00\x00\x00\x00\x00\x02\x0c") for _ in range(2)]
        self.t_us = 0
        self.dt = 1000000 // rate
        self.handler = None
        self.pressed = False

    def set_spi_rate(self, hz):
        pass

    def spi_write(self, chip, buf, n):
        op = buf[0]
        if op & 0xE0 == 0x40:
            self.regs[chip][op & 0x1F] = buf[2]

    def spi_write_readinto(self, chip, w, r, n):
        if w[0] & 0xE0 == 0x20:
            r[2] = self.regs[chip][w[0] & 0x1F]

    def spi_readinto(self, chip, buf):
        cs = self._cs[chip]
        cs(0)
        self._readinto(buf)
        cs(1)

    def set_start(self, v):
        pass

    def set_reset(self, v):
        pass

    def led(self, on):
        pass

    def button(self):
        return self.pressed

    def attach_drdy(self, h, rate=0, on_gap=None):
        self.handler = h

    def busy(self, what, n=1):
        pass   # the bench measures the real cost instead of charging a model

    def ticks_ms(self):
        return (self.t_us // 1000) & 0x3FFFFFFF

    def ticks_diff(self, a, b):
        return ((a - b + 0x20000000) & 0x3FFFFFFF) - 0x20000000

    def sleep_us(self, us):
        self.t_us += us

    def sleep_ms(self, ms):
        self.t_us += 1000 * ms

    def time(self):
        return None

    def quit_requested(self):
        return False

    def idle(self):
        self.t_us += self.dt
        k = self.k + 1
        if k == self.nf:
            k = 0
        self.k = k
        self._seek(k * 18)
        if self.handler is not None:
            # as a hard interrupt runs it: with the heap locked. A Python function whose frame
            # is too big for the C stack's fixed slot puts it on the heap when it can (and frees
            # it after); in a hard IRQ it cannot and takes the C stack. Unlocked, the handler
            # would pay a heap allocation per conversion that a board's handler does not.
            heap_lock()
            self.handler(None)
            heap_unlock()

    # no watchdog on the loop-back board (hal.Board's defaults: bootguard asks at boot)
    def watchdog_start(self, ms):
        return False

    def watchdog_feed(self):
        pass

    def reset_by_watchdog(self):
        return False

    def serial_read(self):
        return None

    def serial_write(self, data):
        pass

    def run(self, app, frames, each=None):
        """The firmware's real main loop (App.step + App.wait) over `frames` DRDY edges of simulated
        time; each(app) after every pass if given (the caller's probe, e.g. a heap reading)."""
        end = self.t_us + frames * self.dt
        while self.t_us < end:
            app.step()
            app.wait()
            if each is not None:
                each(app)

    def handler_costs(self, acq, timer, n):
        """(harness, skip, read, push) per frame: the harness's own idle(), then what the DRDY handler
        adds for a frame outside the boxcar, a frame read and summed, and a block's end with its
        ring pop. timer(loop, n) is the caller's clock for loop(n) over n frames, per frame (wall
        time on unix, instructions bare-metal). Leaves acq at decimation 1; the caller restores it."""
        def idles(m):
            for _ in range(m):
                self.idle()

        def pushes(m):
            for i in range(m):
                self.idle()
                if i & 31 == 31:
                    acq.poll(_nop, 64)
            acq.poll(_nop, 64)
        h = self.handler
        self.handler = None
        harness = timer(idles, n)
        self.handler = h
        acq.set_decimation(1000, 1)
        skip = timer(idles, n) - harness
        acq.set_decimation(64, 64)
        read = timer(idles, n) - harness
        acq.set_decimation(1, 1)
        push = timer(pushes, n) - harness - read
        return harness, skip, read, push


def _nop(sx, sy, sz, st):
    pass


# The App's owners the scripts drive. A revision counted with --before (desktop/bench/cortexm.py)
# may have the App before its state was split among them: there the App is both, and the
# session starts and finishes by App.start_session / App.finish_session.
def parts(app):
    """(calibration flow, survey output) of the firmware's App."""
    return getattr(app, "flow", app), getattr(app, "output", app)


def start_cal(app):
    flow = getattr(app, "flow", None)
    return app.start_session() if flow is None else flow.start()


def finish_cal(app):
    flow = getattr(app, "flow", None)
    return app.finish_session() if flow is None else flow.finish()
