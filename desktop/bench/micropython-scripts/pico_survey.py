# Runs on the emulated Pico (desktop/bench/pico_survey.py): device/survey.py's Output with the
# stream corrected, on survey_stand_ins.py (a data event's line is made, not sent). Reads /disk/job.json {"cal": record, "window": n, "per_block": n, "sums": [[sx, sy,
# sz], ...], "screen_sums": the same with flipped bits}; prints one JSON line, emulated us: per
# decimated sample through Output.sample (the block outputs included; on an emptied heap,
# then with it as full as the firmware's after boot), per |h_c| alone, per
# block output alone, per spike screen push (device/screen.py, on screen_sums: after a
# collection, and again with the heap as full as the firmware's after boot; where its push is
# native, the pure-Python push too); each after a collection, the collections it causes included.
import gc
import json
import sys
import time

sys.path.insert(0, "/disk")
from config import defaults  # noqa: E402
from protocol import Protocol  # noqa: E402
from screen import Screen  # noqa: E402
from shared.calibration import Calibration  # noqa: E402
from survey import Output  # noqa: E402
from survey_stand_ins import Board, Die, Line, Passes  # noqa: E402


def main():
    with open("/disk/job.json") as fh:
        job = json.load(fh)
    cfg = defaults()
    cfg["window"] = job["window"]
    cfg["log"] = False
    o = Output(Board(), Line(len))
    o.adc = Die(25.0)
    o.configure(cfg, cfg["survey_hz"] * job["per_block"])
    o.screen = Passes()
    cal = job["cal"]
    o.use(Calibration.from_dict(cal))
    o.set_stream("corrected")
    sums = job["sums"]
    screen_sums = job["screen_sums"]
    job = None
    gc.collect()
    t0 = time.ticks_us()
    for s in sums:
        o.sample(s[0], s[1], s[2], 0)
    per_sample = time.ticks_diff(time.ticks_us(), t0) / len(sums)
    # again with the heap as full as the firmware's after boot (a heap allocation searches it)
    ballast = _ballast()
    gc.collect()
    t0 = time.ticks_us()
    for s in sums:
        o.sample(s[0], s[1], s[2], 0)
    per_sample_full = time.ticks_diff(time.ticks_us(), t0) / len(sums)
    ballast = None
    # |h_c| alone: the integer correction, or the float one it replaced (cal_w)
    corr = getattr(o, "exact_w", None) or getattr(o, "cal_w", None)
    gc.collect()
    t0 = time.ticks_us()
    for s in sums:
        corr.magnitude(s[0], s[1], s[2])
    magnitude = time.ticks_diff(time.ticks_us(), t0) / len(sums)
    blk = None
    while blk is None:
        s = sums[0]
        f = corr.magnitude(s[0], s[1], s[2])
        blk = o.survey.sample(s[0], s[1], s[2], 0, f)
    gc.collect()
    t0 = time.ticks_us()
    for _ in range(100):
        o._output(blk)
    block = time.ticks_diff(time.ticks_us(), t0) / 100
    # the same through the firmware's Protocol (protocol.py) to a port that takes the bytes
    line, o.proto = o.proto, Protocol(Board(), {}, None)
    gc.collect()
    t0 = time.ticks_us()
    for _ in range(100):
        o._output(blk)
    block_protocol = time.ticks_diff(time.ticks_us(), t0) / 100
    o.proto = line
    finish = _finish(o.survey)
    path = "integers" if hasattr(o, "exact_w") else "floats"
    blk = o = None
    ring = _from_ring(cfg, cal, sums)
    clean, _, _, screen_path = _screen(cfg, sums)
    out = {"screen_clean": clean, "screen_path": screen_path}
    if screen_path == "native":     # the pure-Python push beside it (CircuitPython's)
        out["py_screen_clean"] = _screen(cfg, sums, False)[0]
        out["py_screen"], out["py_screen_full"] = _screen(cfg, screen_sums, False)[:2]
    sums = None
    out["screen"], out["screen_full"], out["screen_spikes"] = _screen(cfg, screen_sums)[:3]
    out.update({"ring": ring, "per_sample": per_sample, "per_sample_full": per_sample_full, "magnitude": magnitude, "block": block,
                "block_protocol": block_protocol, "finish": finish, "path": path,
                "magnitude_path": getattr(corr, "path", "python")})
    print(json.dumps(out))


def _finish(sv):
    """us per Survey.finish of a block whose sums are in the C's words (where they are: else
    None), the words refilled with an open block's sums before each, the refill's own cost taken off."""
    w = sv.words
    if w is None:
        return None
    saved = w[:20]
    us = []
    for call in (False, True):
        gc.collect()
        t0 = time.ticks_us()
        for _ in range(100):
            w[:20] = saved
            if call:
                sv.finish()
        us.append(time.ticks_diff(time.ticks_us(), t0) / 100)
    return us[1] - us[0]


def _from_ring(cfg, record, sums):
    """us per decimated sample from the DRDY ring as the firmware's main loop takes them:
    Acquisition.poll two at a time (a pass's usual count at 100 samples/s) into Output.sample,
    with the firmware's screen (screen.py, screenc.mpy where it loads) and the de-lag by the
    configured response (shared/delag.py, delagc.mpy), block outputs included. The ring is
    filled while the clock is stopped, 100 samples at a time."""
    from acquisition import SLOTS, Acquisition
    from shared.delag import configured_tau_s
    o = Output(Board(), Line(len))
    o.adc = Die(25.0)
    o.configure(cfg, cfg["rate"] / cfg["decim"])
    cal = Calibration.from_dict(record)
    cal.response = {"tau_s": [configured_tau_s(cfg)] * 3}    # as a calibration the board de-lagged
    o.use(cal)
    o.set_stream("corrected")
    acq = o.acq = Acquisition(Board(), cfg["decim"], cfg["window"])
    ring, st = acq.ring, acq.state
    cb, gap = o.sample, o.gap
    blk = 0
    us = 0
    for k in range(0, len(sums), 100):
        for s in sums[k:k + 100]:
            j = st[0] * SLOTS
            ring[j], ring[j + 1], ring[j + 2], ring[j + 3], ring[j + 4] = s[0], s[1], s[2], 0, blk
            blk += 1
            st[0] = (st[0] + 1) % acq.ring_frames
        gc.collect()
        t0 = time.ticks_us()
        while acq.poll(cb, 2, gap):
            pass
        us += time.ticks_diff(time.ticks_us(), t0)
    assert acq.samples == len(sums) and acq.gaps == 0
    return us / len(sums)


class _Nothing:
    """The loop's own cost: a method of the same arguments that does nothing."""

    def push(self, x, y, z, t):
        return False


def _screen_loop(push, sums):
    gc.collect()
    t0 = time.ticks_us()
    for s in sums:
        push(s[0], s[1], s[2], 0)
    return time.ticks_diff(time.ticks_us(), t0) / len(sums)


def _ballast():
    """Small live objects until FREE_B are left: chunks of 256 two-int tuples (16 B each)."""
    out = []
    gc.collect()
    while gc.mem_free() > FREE_B + 6000:
        chunk = [None] * 256
        for j in range(256):
            chunk[j] = (j, len(out))
        out.append(chunk)
    return out


def _screen(cfg, sums, native=True):
    """us per Screen.push, the loop's own cost (the stand-in's push) taken off: on a heap
    emptied by a collection, then with small live objects first until FREE_B are free (the
    firmware's heap after boot, docs/benchmarks.md), where every allocation's search for a
    free block starts at the heap's bottom after a collection (py/gc.c). The screen's push as
    the firmware gets it (in C where screenc.mpy loads: its path), or native=False: the Python."""
    scale = (cfg["scale_x"], cfg["scale_y"], cfg["scale_z"])
    out = []
    for full in (False, True):
        ballast = _ballast() if full else None
        loop = _screen_loop(_Nothing().push, sums)
        if native:
            sc = Screen(scale, cfg["window"], cfg["spike_nt"])
        else:
            sc = Screen(scale, cfg["window"], cfg["spike_nt"], native=False)
        out.append(_screen_loop(sc.push, sums) - loop)
        ballast = None
    return out[0], out[1], sc.spikes, getattr(sc, "path", "python")


FREE_B = 85056     # free after the firmware's boot on the emulated Pico (docs/benchmarks.md)

main()
