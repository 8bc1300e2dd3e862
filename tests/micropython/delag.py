# Runs under each interpreter: shared/delag.py over a job's samples with the heap locked
# (on a 32-bit build an integer past 2**30 - 1 is no small int, and allocating it raises
# MemoryError under the lock), the outputs into a preallocated array.
# argv[1]: the job (JSON: taus_us, rate, decim, window, samples [[x, y, z, t] or null (a hole), ...]);
# argv[2]: the repository root. Prints one JSON line: outputs (flat), saturated, errors.
import json
import sys

sys.path[:0] = [sys.argv[2]]
from array import array  # noqa: E402

import micropython  # noqa: E402
from shared.delag import Delag  # noqa: E402

with open(sys.argv[1]) as f:
    job = json.load(f)
samples = job["samples"]
dl = Delag(job["window"])
dl.set_taus(job["taus_us"], job["rate"], job["decim"])
out = array("i", bytes(4 * 4 * len(samples)))
got = array("i", bytes(4 * len(samples)))    # 1: sample i completed one
errors = []
i = 0
last = len(samples) - 1
micropython.heap_lock()
try:
    for s in samples:
        if s is None:      # a one-sample hole: bridged (join before the sample before it)
            i += 1
            continue
        if i < last and samples[i + 1] is None:
            dl.join(True)
        if dl.push(s[0], s[1], s[2], s[3]):
            out[4 * i] = dl.x
            out[4 * i + 1] = dl.y
            out[4 * i + 2] = dl.z
            out[4 * i + 3] = dl.t
            got[i] = 1
        i += 1
except MemoryError:
    errors.append(i)
micropython.heap_unlock()
print(json.dumps({"out": list(out), "got": list(got), "saturated": dl.saturated, "errors": errors}))
