# MicroPython script for the bare-metal Cortex-M3 board (desktop/bench/cortexm.py imports it
# there from the board's ROM filesystem and calls main()): instruction counts of the
# firmware's paths. A ticks_us difference x 1000 is an instruction count (qemu -icount
# shift=0). The firmware's App runs on a LoopBoard (loopboard.py) whose frames, a simulated
# hand rotation, come from a file in the ROM filesystem (out of the heap); the board's
# flash folder (config) is in the ROM too, so nothing here writes: the calibration is
# finished without storing it and installed by hand for the survey.
# Every count of a loop has the harness's own per-frame work (LoopBoard.idle without a
# handler) subtracted.
import gc
import json
import time
from array import array

from loopboard import LoopBoard, finish_cal, parts, start_cal


def count(t0, t1):
    return time.ticks_diff(t1, t0) * 1000


def per_frame(loop, n):
    t0 = time.ticks_us()
    loop(n)
    return count(t0, time.ticks_us()) // n


def loop(app, board, frames, harness):
    """Instructions of the real main loop (App.step + App.wait) over `frames` DRDY edges."""
    t0 = time.ticks_us()
    board.run(app, frames)
    return count(t0, time.ticks_us()) - frames * harness


def session_module():
    """The firmware's calibration session module (calibrate.py in a revision before it was split)."""
    try:
        import session
    except ImportError:
        import calibrate as session
    return session


def record(app, board, n):
    """n decimated samples (boxcar sums) as the DRDY handler delivers them, for the replays."""
    buf = array("i", bytes(12 * n))
    got = [0]

    def keep(sx, sy, sz, st):
        i = got[0]
        if i < n:
            buf[3 * i] = sx
            buf[3 * i + 1] = sy
            buf[3 * i + 2] = sz
            got[0] = i + 1
    while got[0] < n:
        board.idle()
        app.acq.poll(keep, 64)
    return buf


def replay(session, samples, n):
    t0 = time.ticks_us()
    for i in range(0, 3 * n, 3):
        session.sample(samples[i], samples[i + 1], samples[i + 2])
    return count(t0, time.ticks_us())


def provisional_solve(session, calibrate):
    """Instructions of one provisional solve of the session's fit, as Session.tick runs it (a
    revision before provisional solves were quick solves ran them in full)."""
    it = getattr(calibrate, "_PROVISIONAL_ITER", None)
    gc.collect()
    t0 = time.ticks_us()
    if it is None:
        session._solve()
    else:
        session._solve(it)
    return count(t0, time.ticks_us())


def units(app, board, out, replay_n):
    """The DRDY handler by kind of frame, the gates and add() (replays), a final and a
    provisional solve, and one survey output block; returns the board's harness cost."""
    calibrate = session_module()
    flow, output = parts(app)
    cfg = app.cfg
    harness, skip, read, push = board.handler_costs(app.acq, per_frame, 2000)
    out["harness"] = harness
    out["isr_skip"] = skip
    out["isr_read"] = read
    out["isr_push_pop"] = push
    app._setup_pipeline()
    # the gates and the fit, replayed on recorded samples: once as they run, once with
    # EllipsoidFit.add replaced by an empty function (the gates' decisions do not depend on it
    # without a provisional fit, and the replay has none)
    samples = record(app, board, replay_n)
    period_ms = 1000.0 * cfg["decim"] / cfg["rate"]
    full = calibrate.Session(cfg, output.scale, cfg["window"], period_ms)
    gc.collect()
    t_full = replay(full, samples, replay_n)
    gates = calibrate.Session(cfg, output.scale, cfg["window"], period_ms)

    def no_add(x, y, z):
        pass
    gates.fit.add = no_add
    gc.collect()
    t_gates = replay(gates, samples, replay_n)
    t0 = time.ticks_us()
    for i in range(replay_n):
        no_add(i, i, i)
    t_call = count(t0, time.ticks_us()) // replay_n
    accepted = full.fit.n
    out["replay_samples"] = replay_n
    out["replay_accepted"] = accepted
    out["gates_per_sample"] = (t_gates - accepted * t_call) // replay_n
    out["add_per_accepted"] = (t_full - t_gates) // max(1, accepted) + t_call
    one = (samples[0], samples[1], samples[2])
    samples = gates = None
    gc.collect()
    t0 = time.ticks_us()
    cal = full._solve()
    out["solve"] = count(t0, time.ticks_us())
    out["solve_iterations"] = cal.diagnostics["iterations"]
    out["solve_provisional"] = provisional_solve(full, calibrate)
    full = None
    # one survey output block, streaming corrected with the replay's calibration: correct,
    # format the data event, hand it to the serial line
    output.cal = cal.scaled_input(1.0 / cfg["window"])
    cal = None
    blk = None
    while blk is None:
        blk = output.survey.sample(one[0], one[1], one[2], 0, 48000 * 256000)   # |h_c| 48,000 nT in 1/256 milli-nT
    stream = output.stream
    output.stream = "corrected"
    output._outputs()
    t0 = time.ticks_us()
    for _ in range(20):
        output._output(blk)
    out["output_per_block"] = count(t0, time.ticks_us()) // 20
    output.stream = stream
    output.cal = None
    app._setup_pipeline()
    return harness


def loops(app, board, out, seconds, harness):
    """The whole firmware per second of data: the real main loop calibrating (its steady
    state: one provisional solve per solve_every_s), then in survey streaming corrected."""
    calibrate = session_module()
    flow, output = parts(app)
    cfg = app.cfg
    rate = cfg["rate"]
    start_cal(app)
    s = flow.session
    frames = seconds * rate
    gc.collect()
    n = loop(app, board, frames, harness)
    # (a revision without the counter: the provisional solves a 15 s loop holds, at 5 and 10 s)
    out["cal_solves"] = getattr(s, "solves", (seconds - 1) // cfg["solve_every_s"])
    # one collection of the calibrating firmware's heap: what every ~free-heap bytes of garbage cost
    t0 = time.ticks_us()
    gc.collect()
    out["gc_collect"] = count(t0, time.ticks_us())
    out["heap_live_calibrating"] = gc.mem_alloc()
    out["linalg"] = getattr(flow, "linalg_path", "python")    # the boot's rule: the float kernels taken or not
    prov = provisional_solve(s, calibrate)
    out["calibrating_loop_per_s"] = n // seconds
    # the loop's own count of solves depends on where its end falls: without them, plus one
    # provisional solve per solve_every_s
    out["calibrating_per_s"] = (n - out["cal_solves"] * prov) // seconds + prov // cfg["solve_every_s"]
    out["solve_provisional_loop"] = prov
    out["cal_seen"] = getattr(s, "gates", s).seen   # its gates' count (the session's before they were split)
    out["cal_accepted"] = s.fit.n
    code_cal, reason, msg = s.finish()
    out["cal_state"] = s.state
    flow.session = output.session = None
    if code_cal is None:
        out["cal_reason"] = reason
        return
    # survey, streaming corrected blocks (the flash is read-only here: no log)
    flow.cal = output.cal = code_cal
    output.stream = "corrected"
    app._setup_pipeline()
    gc.collect()
    out["survey_per_s"] = loop(app, board, frames, harness) // seconds
    out["survey_blocks"] = output.survey.blocks


def main(frames_path, root, rate, seconds, replay_n=1200, unit_counts=True):
    import app as appmod
    board = LoopBoard(open(frames_path, "rb"), root, rate)
    app = appmod.App(board)
    cfg = app.cfg
    out = {"rate": cfg["rate"], "decim": cfg["decim"], "window": cfg["window"], "seconds": seconds,
           "blocks_per_s": cfg["survey_hz"]}
    if unit_counts:
        harness = units(app, board, out, replay_n)
    else:
        def idles(m):
            for _ in range(m):
                board.idle()
        h = board.handler
        board.handler = None
        harness = per_frame(idles, 2000)
        board.handler = h
        # 2000 frames with the handler off read as a silent ADC to the health check
        # (health.py, since issue 10): start the pipeline afresh, as units() does
        app._setup_pipeline()
    loops(app, board, out, seconds, harness)
    out["heap_free"] = gc.mem_free()
    print(json.dumps(out))
