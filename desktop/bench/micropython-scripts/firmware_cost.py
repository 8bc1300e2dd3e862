# MicroPython script, run by desktop/bench/device.py in the `micropython` executable
# (data for that benchmark, not a module of the desktop package).
# Measures the firmware's own code paths without the simulator link: a loop-back
# board answers register access from a 12-byte register file and DRDY reads from a
# table of real frames (a hand-rotation capture encoded by the host), so the
# timings are the driver, ring, decimator, gates, fit and survey only.
# argv: frames_file root rate decim window seconds hour(0/1) scale (nT/code). Heap figures exclude
# the frame table (harness data, loaded before the firmware; 256 KB on top of it).
# SPI reads are two C calls (seek, readinto) like machine.SPI.readinto between
# two Pin calls; the harness's own per-frame work is measured and subtracted.
import gc
import io
import sys
import time

FRAME = 9


class LoopBoard:
    REG_BAUD = 1000000
    DATA_BAUD = 8000000

    def __init__(self, frames, root, rate):
        self.nf = len(frames) // (2 * FRAME)
        self.src = io.BytesIO(frames)
        self._seek = self.src.seek
        self._readinto = self.src.readinto
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
            self.handler(None)

    def serial_read(self):
        return None

    def serial_write(self, data):
        pass


BASE = [0]


def heap():
    """Heap held by the firmware: mem_alloc after a collection, minus the harness's frame table."""
    gc.collect()
    return gc.mem_alloc() - BASE[0]


def per_frame(board, n):
    """us per DRDY edge: n idles (harness + handler)."""
    t0 = time.ticks_us()
    for _ in range(n):
        board.idle()
    return time.ticks_diff(time.ticks_us(), t0) / n


def run_loop(app, board, frames):
    """The real main loop (App.step + App.wait) over `frames` DRDY edges; returns us."""
    k0 = board.t_us
    end = k0 + frames * board.dt
    t0 = time.ticks_us()
    while board.t_us < end:
        app.step()
        app.wait()
    return time.ticks_diff(time.ticks_us(), t0)


def main():
    frames_file, root = sys.argv[1], sys.argv[2]
    rate, decim, window, seconds, hour = (int(a) for a in sys.argv[3:8])
    scale = float(sys.argv[8])
    with open(frames_file, "rb") as f:
        frames = f.read()
    gc.collect()
    BASE[0] = gc.mem_alloc()
    import app as appmod
    import store
    from acquisition import OVERFLOW
    out = {}
    store.save(root, "config", {"rate": rate, "decim": decim, "window": window, "scale_x": scale,
                                "scale_y": scale, "scale_z": scale, "auto_finish": False})
    board = LoopBoard(frames, root, rate)
    app = appmod.App(board)
    out["heap_boot"] = heap()
    acq = app.acq

    def nop(a, b, c, d):
        pass
    # DRDY handler cost by kind of frame, minus the harness's own idle()
    n = 20000
    h = board.handler
    board.handler = None
    harness = per_frame(board, n)
    board.handler = h
    acq.set_decimation(1000, 1)
    out["us_isr_skip"] = per_frame(board, n) - harness          # not in the window: counter only
    acq.set_decimation(64, 64)
    out["us_isr_read"] = per_frame(board, n) - harness          # read, parse, sum (no push)
    acq.set_decimation(1, 1)
    t0 = time.ticks_us()
    for i in range(n):
        board.idle()
        if i & 31 == 31:
            acq.poll(nop, 64)
    # read + push + pop from the ring (the decimator's share per sample)
    out["us_isr_push"] = time.ticks_diff(time.ticks_us(), t0) / n - harness - out["us_isr_read"]
    out["us_harness"] = harness
    app._setup_pipeline()   # back to the configured decim/window
    frames_run = seconds * rate
    fd = (window * out["us_isr_read"] + (decim - window) * out["us_isr_skip"] + out["us_isr_push"]) / decim

    # calibration: the real loop over `seconds` of data (gates, coverage, fit.add,
    # provisional solves every solve_every_s, progress events, LED, button)
    app.start_session()
    s = app.session
    dt = run_loop(app, board, frames_run) - frames_run * harness
    out["cal_us_per_s"] = dt / seconds
    out["cal_samples"] = s.seen
    out["cal_accepted"] = s.fit.n
    out["cal_rej"] = [s.rej_rate, s.rej_cap, s.rej_dist]
    out["heap_cal"] = heap()
    t0 = time.ticks_ms()
    cal = s._solve()
    out["ms_solve"] = time.ticks_diff(time.ticks_ms(), t0)
    out["solve_iterations"] = cal.diagnostics.get("iterations")
    r = app.finish_session()
    out["cal_state"] = r["state"]

    # survey: stream off (the handheld alone), then stream corrected at 10 Hz + log on
    dt = run_loop(app, board, frames_run) - frames_run * harness
    out["survey_us_per_s"] = dt / seconds
    app.cfg["log"] = True
    app.stream = "corrected"
    app._setup_pipeline()
    dt = run_loop(app, board, frames_run) - frames_run * harness
    out["stream_us_per_s"] = dt / seconds
    out["frame_us_model"] = fd
    out["heap_survey"] = heap()
    app.stream = "off"
    app._setup_pipeline()

    if hour:
        # a simulated hour of survey (logging to rotating files) at the configured rate
        per_min = 60 * rate
        run_loop(app, board, per_min)   # warm-up: one minute
        h0 = heap()
        marks = []
        for minute in range(1, 60):
            run_loop(app, board, per_min)
            if minute % 10 == 9:
                marks.append(heap())
        out["heap_hour_start"] = h0
        out["heap_hour_marks"] = marks
        out["heap_growth_hour"] = marks[-1] - h0
        out["log_lines"] = app.log.lines if app.log else 0
        out["log_error"] = app.log.error if app.log else None
    out["overflow"] = acq.state[OVERFLOW]
    out["heap_total"] = gc.mem_alloc() + gc.mem_free() - BASE[0]
    import json
    print(json.dumps(out))


main()
