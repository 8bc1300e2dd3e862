# Runs under CPython (the float |h_c|: the reference) and each MicroPython build, from argv or
# main(root, natmod_folder): device/gates.py's disturbance gate judging a slow turn over the
# sphere, with a 300 nT disturbance in the middle, against a provisional calibration, twice:
# once as use_provisional sets it up (the exact |h_c| in C where fitsums.mpy loads), once made
# to take the float |h_c|. Prints one JSON line: the path taken, whether both gates took the
# same samples, and the accepted samples' indices' checksum with the counters, which must be
# CPython's on every interpreter (the samples are integers from a fixed recipe and no sample
# lies within 1e-3 nT of the gate: the float and the exact |h_c| differ by ~1e-9 of the field).
import json
import math
import sys

F = 48000.0                 # nT
UNIT = 0.003                # nT per sum unit (a window of 2 codes)
OFFSET = (1200000, -800000, 400000)       # sum units
DISTURBED = (1400, 1520)    # samples under a 300 nT disturbance (a car, a shovel)
N = 3000                    # 30 s at 100 samples/s


def matrix():
    """M (nT per sum unit): gains 2 % apart and small cross terms, symmetric."""
    e = ((0.02, 0.004, -0.003), (0.004, -0.01, 0.002), (-0.003, 0.002, 0.005))
    return [[UNIT * ((1.0 if i == j else 0.0) + e[i][j]) for j in range(3)] for i in range(3)]


def inverse(m):
    a, b, c = m[0]
    d, e, f = m[1]
    g, h, k = m[2]
    det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)
    return [[(e * k - f * h) / det, (c * h - b * k) / det, (b * f - c * e) / det],
            [(f * g - d * k) / det, (a * k - c * g) / det, (c * d - a * f) / det],
            [(d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det]]


def step(i):
    """The disturbance, nT along x: 300 nT for DISTURBED's samples."""
    return 300.0 if DISTURBED[0] <= i < DISTURBED[1] else 0.0


def samples(disturbance=step, first=0):
    """The sums of a turn at ~30 deg/s along a spiral over the sphere (made as they are taken:
    a list of them is more than a small heap holds), `disturbance(i)` nT added along x, from
    sample `first`."""
    mi = inverse(matrix())
    for i in range(first, N):
        t = i / 100.0
        theta = math.acos(1.0 - 2.0 * (i + 0.5) / N)     # pole to pole once
        phi = 0.5 * t                                  # ~0.5 rad/s around
        h = [F * math.sin(theta) * math.cos(phi), F * math.sin(theta) * math.sin(phi), F * math.cos(theta)]
        h[0] += disturbance(i)
        yield [int(round(mi[r][0] * h[0] + mi[r][1] * h[1] + mi[r][2] * h[2] + OFFSET[r])) for r in range(3)]


def run(gates_mod, cfg, cal, exact):
    from shared.coverage import Coverage
    from shared.fit import EllipsoidFit
    fit = EllipsoidFit()
    cov = Coverage(cfg["cells"], cfg["cell_cap"])
    g = gates_mod.Gates(cfg, fit, cov, 2, 10.0, OFFSET)
    g.use_provisional(cal, 20.0)
    path = "python" if g._exact is None else "native"
    if not exact:
        g._exact = None
    taken = []
    for i, s in enumerate(samples()):
        if g.sample(s[0], s[1], s[2]):
            taken.append(i)
    return path, taken, {"rej_dist": g.rej_dist, "removed": g.removed, "rej_rate": g.rej_rate,
                         "rej_cap": g.rej_cap, "n": fit.n}


def main(root, natmod=None):
    for folder in (natmod, root + "/device", root):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    import config
    import gates
    from shared.calibration import Calibration
    cal = Calibration(matrix(), list(OFFSET), F)
    cfg = config.defaults()
    path, exact, counts = run(gates, cfg, cal, True)
    _, floats, counts_f = run(gates, cfg, cal, False)
    check = 0
    for i in exact:
        check = (check * 31 + i) & 0xFFFFFF
    print(json.dumps({"path": path, "same": exact == floats and counts == counts_f, "checksum": check,
                      "counts": counts}))


if __name__ == "__main__" and len(sys.argv) > 2:    # a board without argv imports it and calls main()
    main(sys.argv[1], sys.argv[2] or None)
