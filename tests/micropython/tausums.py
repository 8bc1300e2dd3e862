# Runs under each interpreter: shared/delag.py with tau steps and shared/tausums.py over a job's
# samples: the four node accumulators (and the fit's own, t = 0) take each de-lagged sample
# and its step; prints the sums interpolated at the job's (p, q) pairs, as decimal strings.
# argv[1]: the job (JSON: taus_us, steps_us, rate, decim, window, samples, drop, at);
# argv[2]: the repository root.
import json
import sys

sys.path[:0] = [sys.argv[2]]
from shared.delag import Delag  # noqa: E402
from shared.fit import EllipsoidFit  # noqa: E402
from shared.tausums import TauSums, lagrange_sums  # noqa: E402

with open(sys.argv[1]) as f:
    job = json.load(f)
dl = Delag(job["window"])
dl.set_taus(job["taus_us"], job["rate"], job["decim"], job["steps_us"])
fit = EllipsoidFit()
ts = TauSums()
kept = []
for s in job["samples"]:
    if dl.push(s[0], s[1], s[2], s[3]):
        v = (dl.x, dl.y, dl.z, dl.ex, dl.ey, dl.ez)
        fit.add(v[0], v[1], v[2])
        ts.add(*v)
        kept.append(v)
for i in job["drop"]:                 # removal is the exact inverse (the gates' back-off)
    v = kept[i]
    fit.remove(v[0], v[1], v[2])
    ts.remove(*v)
centre = fit.sums()
nodes = ts.sums()
out = [[str(v) for v in lagrange_sums(centre, nodes, p, q)] for p, q in job["at"]]
print(json.dumps({"kept": len(kept), "sums": out}))
