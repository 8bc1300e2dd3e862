# Runs under the real `micropython` executable (and CPython): reads a JSON job
# {"points": [[x, y, z], ...], "field": F or null, "scale": s} from the file
# named in argv[1], fits it with shared.fit and prints one JSON result line.
import json
import sys

sys.path.insert(0, sys.argv[2])
from shared.fit import EllipsoidFit, FitError  # noqa: E402

with open(sys.argv[1]) as fh:
    job = json.load(fh)
fit = EllipsoidFit()
for p in job["points"]:
    fit.add(p[0], p[1], p[2])
out = {"sums": [str(s) for s in fit.sums()]}
try:
    cal = fit.solve(field=job["field"], scale=job["scale"])
    out["calibration"] = cal.to_dict()
except FitError as exc:
    out["reason"] = exc.reason
print(json.dumps(out))
