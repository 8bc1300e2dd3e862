# Runs under each interpreter and CPython: reads {"edges": [n, ...], "dirs": [[x, y, z], ...]}
# from argv[1] (repository root argv[2]); a component is an integer, or a float written as a
# string "N/D" with D a power of two, made by one exact division (a single-precision
# MicroPython parses "-0.767333984375" an ulp off), or "-0.0" (a signed zero). Prints one JSON line: for each
# edge, Coverage(edge).cell of every direction, or "ValueError" where it refuses one.
import json
import sys

sys.path.insert(0, sys.argv[2])
from shared.coverage import Coverage  # noqa: E402

with open(sys.argv[1]) as fh:
    job = json.load(fh)


def number(v):
    if not isinstance(v, str):
        return v
    if v == "-0.0":
        return -1.0 * 0.0
    num, den = v.split("/")
    return float(int(num)) / int(den)


dirs = [[number(v) for v in d] for d in job["dirs"]]
out = []
for edge in job["edges"]:
    cov = Coverage(edge)
    cells = []
    for x, y, z in dirs:
        try:
            cells.append(cov.cell(x, y, z))
        except ValueError:
            cells.append("ValueError")
    out.append(cells)
print(json.dumps(out))
