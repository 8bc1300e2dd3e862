# Runs under each interpreter: reads {"cal": calibration dict, "codes": [[x, y, z], ...]}
# from argv[1] (repository root argv[2]) and prints one JSON line: Calibration.magnitude
# and Calibration.correct of every integer code triple, as repr strings (all digits the
# interpreter's float has).
import json
import sys

sys.path.insert(0, sys.argv[2])
from shared.calibration import Calibration  # noqa: E402

with open(sys.argv[1]) as fh:
    job = json.load(fh)
cal = Calibration.from_dict(job["cal"])
mags = []
vecs = []
for x, y, z in job["codes"]:
    mags.append(repr(cal.magnitude(x, y, z)))
    vecs.append([repr(v) for v in cal.correct(x, y, z)])
print(json.dumps({"magnitude": mags, "correct": vecs}))
