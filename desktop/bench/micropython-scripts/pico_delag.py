# Runs on the emulated Pico (desktop/bench/pico_delag.py): shared/delag.py's Delag.push alone on
# /disk/job.json's sums (a spin's, window 2), at the firmware's defaults (tau 31,839 us, 1000
# SPS, decim 10), without and with tau steps (a calibration estimating tau), the push as the
# firmware gets it (in C where delagc.mpy loads) and the pure-Python one (native=False); prints
# one JSON line, emulated us a push, the loop's own cost (a stand-in's push) taken off, after a
# collection, the collections it causes included.
import gc
import json
import sys
import time

sys.path.insert(0, "/disk")
from shared.delag import Delag  # noqa: E402


class _Nothing:
    def push(self, x, y, z, t):
        return False


def _loop(push, sums):
    gc.collect()
    t0 = time.ticks_us()
    for s in sums:
        push(s[0], s[1], s[2], 0)
    return time.ticks_diff(time.ticks_us(), t0) / len(sums)


def main():
    with open("/disk/job.json") as fh:
        sums = json.load(fh)["sums"]
    out = {"path": Delag(2).path}
    loop = _loop(_Nothing().push, sums)
    for steps in (None, [3000, 3000, 3000]):
        for native in (True, False):
            dl = Delag(2, native)
            dl.set_taus([31839, 31839, 31839], 1000, 10, steps)
            key = "%s_%s" % ("steps" if steps else "plain", "native" if native else "python")
            out[key] = _loop(dl.push, sums) - loop
    print(json.dumps(out))


main()
