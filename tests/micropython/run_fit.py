# Runs under each interpreter (the micropython builds, CircuitPython, and CPython):
# reads a JSON job {"points": [[x, y, z], ...], "field": F or null, "scale": s}
# from the file named in argv[1], fits it with shared.fit (the repository root
# is argv[2]) and prints one JSON line: the exact power sums, the calibration,
# and the solver's fixed-point integer state at convergence (read by wrapping
# shared.solver._finish, which receives it).
import json
import sys

sys.path.insert(0, sys.argv[2])
from shared import solver  # noqa: E402
from shared.fit import EllipsoidFit, FitError  # noqa: E402

states = []
_finish = solver._finish


def _spy(pb, pr, st, *args):
    states.append([[str(x) for x in st.a_int], [str(x) for x in st.f_int]])
    return _finish(pb, pr, st, *args)


solver._finish = _spy
with open(sys.argv[1]) as fh:
    job = json.load(fh)
fit = EllipsoidFit()
for p in job["points"]:
    fit.add(p[0], p[1], p[2])
out = {"sums": [str(s) for s in fit.sums()]}
try:
    cal = fit.solve(field=job["field"], scale=job["scale"])
    out["calibration"] = cal.to_dict()
    out["state"] = states[-1]
except FitError as exc:
    out["reason"] = exc.reason
print(json.dumps(out))
