# Runs under each interpreter: device/survey.py's Output (its |h_c| per sample, block averages
# and data events, the correction in shared/fixedpoint.py) on the stand-ins of
# desktop/bench/micropython-scripts/survey_stand_ins.py (every sample passes, as the window sums
# given). argv[1] a JSON case {"cal": record, "window": n, "per_block": n,
# "temp": C or null, "sums": [[sx, sy, sz], ...]}, argv[2] the repository root, argv[3] (if
# given) the folder of the fitsums.mpy to load; on the emulated Pico (no argv) /disk/job.json,
# the modules and fitsums.mpy in /disk. Prints every data event line as sent (kept, they would
# scatter over the heap between collections and leave no room for one long line); with a natmod folder, then "#native" or "#python": whether
# fitsums.survey took the samples, fitsums.correct the blocks and fitsums.line wrote lines (its
# buffer there while the stream is on, not after).
import json
import sys

if len(sys.argv) > 2:
    case_path, root, natmod = sys.argv[1], sys.argv[2], (sys.argv[3] if len(sys.argv) > 3 else None)
else:
    case_path, root, natmod = "/disk/job.json", "/disk", "/disk"
for folder in (root + "/device", root + "/desktop/bench/micropython-scripts", root, natmod):
    if folder and folder not in sys.path:
        sys.path.insert(0, folder)
from config import defaults  # noqa: E402
from shared.calibration import Calibration  # noqa: E402
from survey import Output  # noqa: E402
from survey_stand_ins import Board, Die, Line, Passes  # noqa: E402


with open(case_path) as fh:
    case = json.load(fh)
cfg = defaults()
cfg["window"] = case["window"]
cfg["decim"] = max(cfg["decim"], case["window"])
cfg["log"] = False
written = [0]      # lines fitsums.line wrote: a view of the Output's buffer (Python's `%` makes bytes)


def out(line):
    written[0] += type(line) is memoryview
    print(bytes(line).decode(), end="")


o = Output(Board(), Line(out))
o.adc = Die(case["temp"] if case["temp"] is not None else 25.0)
o.configure(cfg, cfg["survey_hz"] * case["per_block"])
o.screen = Passes()
o.temp_c = case["temp"]          # the die's temperature known from the start
o.use(Calibration.from_dict(case["cal"]))
o.set_stream("corrected")
for sx, sy, sz in case["sums"]:
    o.sample(sx, sy, sz, 0)
if natmod:
    ex = o.exact_blk
    buffered = o._line is not None
    o.set_stream("off")             # the line's buffer goes back to the heap
    print("#native" if o._words is not None and ex is not None and ex.path == "native" and written[0] and buffered
          and o._line is None else "#python")
