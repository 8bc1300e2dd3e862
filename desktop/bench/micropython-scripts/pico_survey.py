# Runs on the emulated Pico (desktop/bench/pico_survey.py): device/survey.py's Output with the
# stream corrected, on survey_stand_ins.py (a data event's members are made, not sent). Reads /disk/job.json {"cal": record, "window": n, "per_block": n, "sums": [[sx, sy,
# sz], ...]}; prints one JSON line, emulated us: per decimated sample through Output.sample
# (the block outputs included), per |h_c| alone, per block output alone; each after a
# collection, the collections it causes included.
import gc
import json
import sys
import time

sys.path.insert(0, "/disk")
from config import defaults  # noqa: E402
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
    o.use(Calibration.from_dict(job["cal"]))
    o.set_stream("corrected")
    sums = job["sums"]
    job = None
    gc.collect()
    t0 = time.ticks_us()
    for s in sums:
        o.sample(s[0], s[1], s[2], 0)
    per_sample = time.ticks_diff(time.ticks_us(), t0) / len(sums)
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
    print(json.dumps({"per_sample": per_sample, "magnitude": magnitude, "block": block,
                      "path": "integers" if hasattr(o, "exact_w") else "floats",
                      "magnitude_path": getattr(corr, "path", "python")}))


main()
