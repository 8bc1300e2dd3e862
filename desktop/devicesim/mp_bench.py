# MicroPython script (run by desktop/bench_device.py in the `micropython` executable).
# Measures the firmware's own code paths without the simulator link: a loop-back
# board answers register access from a 12-byte register file and DRDY reads from a
# table of real frames (a hand-rotation capture encoded by the host), so the
# timings are the driver, ring, decimator, gates, fit and survey only.
# argv: frames_file root rate hour_rate. Heap figures exclude the frame table
# (harness data, loaded before the firmware; the run gets 256 KB on top of it).
import gc
import sys
import time

FRAME = 9


class LoopBoard:
    REG_BAUD = 1000000
    DATA_BAUD = 8000000

    def __init__(self, frames, root, rate):
        self.frames = frames
        self.nf = len(frames) // (2 * FRAME)
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
        i = (self.k * 2 + chip) * FRAME
        f = self.frames
        for j in range(FRAME):
            buf[j] = f[i + j]

    def set_start(self, v):
        pass

    def set_reset(self, v):
        pass

    def led(self, on):
        pass

    def button(self):
        return self.pressed

    def attach_drdy(self, h):
        self.handler = h

    def ticks_us(self):
        return self.t_us & 0x3FFFFFFF

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
        self.k = (self.k + 1) % self.nf
        if self.handler is not None:
            self.handler(None)

    def serial_read(self):
        return None

    def serial_write(self, data):
        pass

    def log(self, text):
        pass


BASE = [0]


def heap():
    """Heap held by the firmware: mem_alloc after a collection, minus the harness's frame table."""
    gc.collect()
    return gc.mem_alloc() - BASE[0]


def run_frames(app, board, n):
    for _ in range(n):
        board.idle()
        app.step()


def main():
    frames_file, root, rate, hour_rate = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    with open(frames_file, "rb") as f:
        frames = f.read()
    gc.collect()
    BASE[0] = gc.mem_alloc()
    import app as appmod
    import store
    out = {}
    store.save(root, "config", {"rate": rate, "scale_x": 0.0144, "scale_y": 0.0144, "scale_z": 0.0144,
                                "auto_finish": False})
    board = LoopBoard(frames, root, rate)
    app = appmod.App(board)
    out["heap_boot"] = heap()
    adc, dec = app.adc, app.dec

    # acquisition path: ISR (2 SPI reads, parse, ring) + decimator, per frame
    def nop(a, b, c, d):
        pass
    n = 20000
    t0 = time.ticks_us()
    for _ in range(n):
        board.idle()
        dec.poll(nop, 8)
    out["us_per_frame_acq"] = time.ticks_diff(time.ticks_us(), t0) / n
    t0 = time.ticks_us()
    for _ in range(n):
        board.idle()
    out["us_per_frame_isr"] = time.ticks_diff(time.ticks_us(), t0) / n
    dec.poll(nop, 100000)

    # calibration path: everything per decimated sample (gates, coverage, fit.add,
    # temperature, survey |h_c|) measured as the whole main loop minus acquisition
    app._start_session()
    s = app.session
    n = 60000
    t0 = time.ticks_us()
    run_frames(app, board, n)
    dt = time.ticks_diff(time.ticks_us(), t0)
    samples = n // app.cfg["decim"]
    out["us_per_sample_cal"] = (dt - n * out["us_per_frame_acq"]) / samples
    out["cal_accepted"] = s.fit.n
    out["heap_cal"] = heap()
    t0 = time.ticks_ms()
    cal = s._solve()
    out["ms_solve"] = time.ticks_diff(time.ticks_ms(), t0)
    out["solve_iterations"] = cal.diagnostics.get("iterations")
    out["heap_peak_note"] = "mem_alloc after gc.collect"
    r = app._finish_session()
    out["cal_state"] = r["state"]

    # survey path: per decimated sample with the calibration applied, streaming off, logging on
    app.cfg["log"] = True
    app._setup_pipeline()
    n = 20000
    t0 = time.ticks_us()
    run_frames(app, board, n)
    dt = time.ticks_diff(time.ticks_us(), t0)
    out["us_per_sample_survey"] = (dt - n * out["us_per_frame_acq"]) / (n // app.cfg["decim"])
    out["heap_survey"] = heap()

    # a simulated hour of survey (logging to rotating files) at hour_rate SPS
    app.cfg["rate"] = hour_rate
    board.dt = 1000000 // hour_rate
    app._setup_pipeline()
    per_min = 60 * hour_rate
    run_frames(app, board, per_min)   # warm-up: one minute
    h0 = heap()
    marks = []
    for minute in range(1, 60):
        run_frames(app, board, per_min)
        if minute % 10 == 9:
            marks.append(heap())
    out["heap_hour_start"] = h0
    out["heap_hour_marks"] = marks
    out["heap_growth_hour"] = marks[-1] - h0
    out["log_lines"] = app.log.lines if app.log else 0
    out["log_error"] = app.log.error if app.log else None
    out["overflow"] = adc.state[2]
    out["heap_total"] = gc.mem_alloc() + gc.mem_free() - BASE[0]
    import json
    print(json.dumps(out))


main()
