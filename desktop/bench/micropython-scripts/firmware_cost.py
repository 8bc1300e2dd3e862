# MicroPython script, run by desktop/bench/device.py in the `micropython` executable
# (data for that benchmark, not a module of the desktop package).
# Measures the firmware's own code paths without the simulator link: a loop-back
# board (loopboard.py, found next to this script: micropython puts a script's folder first on
# sys.path) answers register access from a 12-byte register file and DRDY reads from a table of
# real frames (a hand-rotation capture encoded by the host, read into RAM through io.BytesIO),
# so the timings are the driver, ring, decimator, gates, fit and survey only.
# argv: frames_file root rate decim window seconds hour(0/1) scale (nT/code). Heap figures exclude
# the frame table (harness data, loaded before the firmware; 256 KB on top of it).
# SPI reads are two C calls (seek, readinto) like machine.SPI.readinto between
# two Pin calls; the harness's own per-frame work is measured and subtracted.
# Per-frame costs are the median of BLOCKS blocks (one preemption of this shared machine
# in a single short block would otherwise shift every figure the harness is subtracted from).
# Besides wall time (ticks_us), each main-loop run also records the process's CPU time
# (time.clock, 1 ms resolution) and the time it waited for a core (run_delay in
# /proc/self/schedstat, Linux only): keys *_cpu_us_per_s and *_wait_frac. Both are read
# without allocating on the firmware's heap (a fragmented heap fails the firmware's own
# 8 KB read-back in store.save).
import gc
import io
import sys
import time

from loopboard import LoopBoard, finish_cal, parts, start_cal

BLOCKS = 5


class Sched:
    """Run-queue wait (ns) of this process from /proc/self/schedstat, read into a buffer opened
    before the heap baseline; 0 where there is no such file."""

    def __init__(self):
        self.buf = bytearray(96)
        try:
            self.f = open("/proc/self/schedstat", "rb")
        except OSError:
            self.f = None

    def wait_ns(self):
        f, buf = self.f, self.buf
        if f is None:
            return 0
        f.seek(0)
        n = f.readinto(buf)
        k = 0
        while k < n and buf[k] != 32:     # first field: on-CPU ns (lags by up to a tick); skip
            k += 1
        k += 1
        v = 0
        while k < n and 48 <= buf[k] <= 57:
            v = v * 10 + buf[k] - 48
            k += 1
        return v


SCHED = [None]
BASE = [0]


def heap():
    """Heap held by the firmware: mem_alloc after a collection, minus the harness's frame table."""
    gc.collect()
    return gc.mem_alloc() - BASE[0]


def median(v):
    v = sorted(v)
    m = len(v) // 2
    return v[m] if len(v) % 2 else (v[m - 1] + v[m]) / 2


def per_frame(loop, n):
    """us per DRDY edge of loop(m): the median of BLOCKS blocks of m = n // BLOCKS frames."""
    m = n // BLOCKS
    wall = []
    for _ in range(BLOCKS):
        t0 = time.ticks_us()
        loop(m)
        wall.append(time.ticks_diff(time.ticks_us(), t0) / m)
    return median(wall)


def run_loop(app, board, frames, cpu=None):
    """The real main loop (App.step + App.wait) over `frames` DRDY edges; returns wall us.
    If `cpu` is a list, (process CPU us, run-queue wait us) over the loop is appended to it."""
    sched = SCHED[0]
    w0 = sched.wait_ns()
    c0 = time.clock()
    t0 = time.ticks_us()
    board.run(app, frames)
    dt = time.ticks_diff(time.ticks_us(), t0)
    c1 = time.clock()
    w1 = sched.wait_ns()
    if cpu is not None:
        cpu.append(((c1 - c0) * 1e6, (w1 - w0) / 1000))
    return dt


def main():
    frames_file, root = sys.argv[1], sys.argv[2]
    rate, decim, window, seconds, hour = (int(a) for a in sys.argv[3:8])
    scale = float(sys.argv[8])
    with open(frames_file, "rb") as f:
        frames = f.read()
    SCHED[0] = Sched()
    gc.collect()
    BASE[0] = gc.mem_alloc()
    import app as appmod
    import store
    from acquisition import OVERFLOW
    out = {}
    store.save(root, "config", {"rate": rate, "decim": decim, "window": window, "scale_x": scale,
                                "scale_y": scale, "scale_z": scale, "auto_finish": False})
    board = LoopBoard(io.BytesIO(frames), root, rate)
    app = appmod.App(board)
    out["heap_boot"] = heap()
    acq = app.acq

    # DRDY handler cost by kind of frame, minus the harness's own idle()
    harness, skip, read, push = board.handler_costs(acq, per_frame, 20000)
    out["us_isr_skip"] = skip       # not in the window: counter only
    out["us_isr_read"] = read       # read, parse, sum (no push)
    out["us_isr_push"] = push       # read + push + pop from the ring (the decimator's share per sample)
    out["us_harness"] = harness

    def record(name, dt, cpu):
        """us/s of data from the wall time dt and from the process CPU time (both minus the
        harness's median per-frame wall time); the share of dt spent waiting for a core."""
        out[name + "_us_per_s"] = (dt - frames_run * harness) / seconds
        out[name + "_cpu_us_per_s"] = (cpu[0][0] - frames_run * harness) / seconds
        out[name + "_wait_frac"] = cpu[0][1] / dt if dt > 0 else 0.0

    app._setup_pipeline()   # back to the configured decim/window
    frames_run = seconds * rate
    fd = (window * out["us_isr_read"] + (decim - window) * out["us_isr_skip"] + out["us_isr_push"]) / decim

    # calibration: the real loop over `seconds` of data (gates, coverage, fit.add,
    # provisional solves every solve_every_s, progress events, LED, button)
    flow, output = parts(app)
    start_cal(app)
    s = flow.session
    cpu = []
    record("cal", run_loop(app, board, frames_run, cpu), cpu)
    g = getattr(s, "gates", s)   # the gates' counts (the session's before they were split)
    out["cal_samples"] = g.seen
    out["cal_accepted"] = s.fit.n
    out["cal_rej"] = [g.rej_rate, g.rej_cap, g.rej_dist]
    out["heap_cal"] = heap()
    solves = []
    c0 = time.clock()
    for _ in range(BLOCKS):     # the solve is pure (the accumulator is unchanged): BLOCKS of them
        t0 = time.ticks_us()
        cal = s._solve()
        solves.append(time.ticks_diff(time.ticks_us(), t0) / 1000)
    out["ms_solve"] = (time.clock() - c0) * 1000 / BLOCKS      # process CPU time per solve
    out["ms_solve_wall"] = median(solves)
    out["solve_iterations"] = cal.diagnostics.get("iterations")
    r = finish_cal(app)
    out["cal_state"] = r["state"]

    # survey: stream off (the handheld alone), then stream corrected at 10 Hz + log on
    cpu = []
    record("survey", run_loop(app, board, frames_run, cpu), cpu)
    app.cfg["log"] = True
    output.stream = "corrected"
    app._setup_pipeline()
    cpu = []
    record("stream", run_loop(app, board, frames_run, cpu), cpu)
    out["frame_us_model"] = fd
    out["heap_survey"] = heap()
    output.stream = "off"
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
        out["log_lines"] = output.log.lines if output.log else 0
        out["log_error"] = output.log.error if output.log else None
    out["overflow"] = acq.state[OVERFLOW]
    out["heap_total"] = gc.mem_alloc() + gc.mem_free() - BASE[0]
    import json
    print(json.dumps(out))


main()
