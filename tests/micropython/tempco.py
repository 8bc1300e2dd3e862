# Runs under each interpreter: reads a JSON job from argv[1] (repository root argv[2]):
# {"cals": [calibration records with meta.temperature_c], "record": a calibration with a
#  tempco, "temps": [C, ...], "codes": [[x, y, z], ...] integers,
#  "warmup": {"samples": [[x, y, z], ...], "temps": [C, ...], "scale": s} or absent}
# and prints one JSON line, floats as repr strings (every digit the interpreter has):
# "tempco": fit_tempco(cals); "magnitude": per temperature, record.at_temperature(T).magnitude
# of every code triple; "in_range": record.tempco_in_range(T); "warmup": WarmupFit's tempco.
import json
import sys

sys.path.insert(0, sys.argv[2])
from shared.calibration import Calibration
from shared.tempco import fit_tempco
from shared.warmup import WarmupFit


def reprs(tc):
    out = {}
    for k in tc:
        v = tc[k]
        if isinstance(v, list):
            out[k] = [repr(x) for x in v]
        elif isinstance(v, float):
            out[k] = repr(v)
        else:
            out[k] = v
    return out


with open(sys.argv[1]) as fh:
    job = json.load(fh)
out = {"tempco": reprs(fit_tempco([Calibration.from_dict(d) for d in job["cals"]]))}
rec = Calibration.from_dict(job["record"])
mags = []
for t in job["temps"]:
    c = rec.at_temperature(t)
    mags.append([repr(c.magnitude(x, y, z)) for x, y, z in job["codes"]])
out["magnitude"] = mags
out["in_range"] = [rec.tempco_in_range(t) for t in job["temps"]]
w = job.get("warmup")
job = None
if w:
    fit = WarmupFit()
    temps = w["temps"]
    samples = w["samples"]
    for i in range(len(samples)):
        p = samples[i]
        fit.add(p[0], p[1], p[2], temps[i])
    samples = None
    cal = fit.solve(scale=w["scale"])
    out["warmup"] = reprs(cal.tempco)
    out["warmup_offset"] = [repr(v) for v in cal.offset]
    out["warmup_kinds"] = [s["kind"] for s in fit.segments]
print(json.dumps(out))
