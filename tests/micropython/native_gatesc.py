# Runs under CPython (the pure-Python Gates.sample alone: the reference) and each MicroPython/
# CircuitPython board (with the native sample where gatesc.mpy loads), from argv or
# main(root, natmod_folder[, short]): puts the folder holding gatesc.mpy and the repository
# (device/, shared/, tests/micropython/) on sys.path and feeds the same sums to two of
# device/gates.py's Gates, Gates(..., native=False) (the reference) and Gates (native where the
# module loads), each with its own fit and coverage. After every sample the verdict, the whole
# state (_st: counters, chain, hist ring position), the rate gate's ring and the residual
# batches' open and left counts (gatesc.c keeps them) must be the same; after each scenario the
# coverage counts, the hist ring, the fit's sums and the residual batches' counts and float
# sums too. A board (short) runs its integer scenarios through the native Gates alone: their
# every verdict and state goes into the checksum compared with CPython's pure-Python gates.
# Scenarios: a slow spiral (nearly all taken, then full cells), a hand's turns and
# reversals at a slow gate (stride > 1: rate rejections), random sums over the whole range,
# the cells' boundaries (face edges, ties, cuts and a unit either side, zero components) and
# the +-2**23 extremes, a centre that puts shifted sums past the C words (+-2**15), sums past
# a 32-bit port's small ints and past +-2**31, a provisional calibration with a 300 nT
# disturbance (its back-off and hold: gates_native.py's turn), and the tau sums attached.
# Prints one line per scenario (the reference's counters and a checksum of every verdict and
# state: compared with CPython's), then one JSON line: the gates' path, the samples where the
# two differed, per scenario the samples the native sample handed to Python, and what 20 samples
# through the native gates (the disturbance gate on) raised with the heap locked.
import gc
import json
import sys
from array import array

TOP = 1 << 23
MASK = 0x3FFFFFFF
# (window, cells, cell_cap, gate_rate_dps, centre, kind, samples)
SCENARIOS = ((2, 6, 40, 360.0, (0, 0, 0), "smooth", 1200),
             (2, 4, 5, 360.0, (120000, -80000, 40000), "smooth", 800),
             (1, 3, 40, 20.0, (0, 0, 0), "hand", 800),
             (64, 12, 40, 360.0, (-5000000, 3000000, 0), "hand", 600),
             (3, 2, 1000, 360.0, (0, 0, 0), "random", 600),
             (2, 6, 1000, 360.0, (0, 0, 0), "edges", 0),
             (1, 5, 1000, 360.0, (0, 0, 0), "edges", 0),
             (2, 6, 1000, 360.0, (-(1 << 26) + TOP, 1 << 25, 0), "edges", 0),    # x past 2**15: Python
             (2, 6, 40, 360.0, (0, 0, 0), "big", 400),
             (2, 6, 40, 360.0, None, "disturbed", 3000),
             (2, 6, 40, 360.0, (0, 0, 0), "tau", 300),
             (2, 6, 40, 360.0, None, "tail", 2000))
# their sums are made with floats: CPython's are compared by verdicts and counts
FLOATS = ("disturbed", "tail")
# a board (short) runs them from before the disturbance (sample 1400) to after its hold (~1700)
SHORT_FLOATS = (1300, 1900)


def tail(i):
    """A disturbance that steps to 300 nT and falls off as a cube over 2 s (a dipole passing):
    the hold after it restarts while it is above a tenth of the gate."""
    return 300.0 * ((1600 - i) / 200.0) ** 3 if 1400 <= i < 1600 else 0.0


class _Lag:
    """A Delag's tau steps (.ex .ey .ez) and the tau sums they go into, for the "tau" scenario."""
    ex = 3
    ey = -2
    ez = 1

    def __init__(self):
        self.n = 0

    def add(self, x, y, z, ex, ey, ez):
        self.n += x - y + z + ex


def hand(rng, n, window, smooth=False):
    """A field turning with reversals and noise (integers: the same on every interpreter); a
    hand's now and then a gap (None: break_chain), a smooth one slower and without gaps."""
    p = [3000000 * window, -1500000 * window, 800000 * window]
    v = [rng.signed(14) * window, rng.signed(14) * window, rng.signed(12) * window]
    full = TOP * window
    for _ in range(n):
        for a in range(3):
            v[a] += rng.signed(8 if smooth else 10) * window
            if not -full // 2 < p[a] + v[a] < full // 2:
                v[a] = -v[a]
            p[a] += v[a]
        if not smooth and rng.bits(6) == 0:
            yield None
        yield (p[0] + rng.signed(6), p[1] + rng.signed(6), p[2] + rng.signed(6))


def edges(g, window, cells, short):
    """Each direction `stride + 1` times after a break: the last one is judged at no turn. The
    cells' boundaries in the gates' 14-bit units (shifted up), then the raw extremes; a board
    (short) every third of them (the x86 and x64 builds of the same C take them all)."""
    import math
    sh = 0                  # the gates' shift (gates.py: its slot's name is a const there)
    while (window << 23) >> sh >= 1 << 14:
        sh += 1
    big = (1 << 14) - 1
    dirs = []
    for m in (1, 7, 4096, big):
        for a in (-m, 0, m):
            for b in (-m, 0, m):
                for c in (-m, 0, m):
                    dirs.append((a, b, c))
    for k in range(1, cells):
        t = int(round(math.tan(math.radians(-45.0 + 90.0 * k / cells)) * 4096))
        for major in (4096, 4000):
            p = t * major // 4096
            for d in (-1, 0, 1):
                for sign in (1, -1):
                    dirs += [(sign * major, p + d, p + d), (p + d, sign * major, -(p + d)), (p + d, p - d, sign * major)]
    out = [(a << sh, b << sh, c << sh) for a, b, c in dirs]
    full = TOP * window
    ext = (-full, full - 1, -full + 1, 0, 1, -1, full >> 1)
    out += [(a, b, c) for a in ext for b in ext for c in ext]
    for d in out[::3] if short else out:
        yield None
        for _ in range(len(g._ring) // 3 + 1):     # the stride
            yield d


def stream(kind, n, rng, window, gates_mod, g, cells, short):
    if kind in ("smooth", "tau"):
        return hand(rng, n, window, True)
    if kind == "hand":
        return hand(rng, n, window)
    if kind == "random":
        return ((rng.signed(23) * window, rng.signed(23) * window, rng.signed(23) * window) for _ in range(n))
    if kind == "edges":
        return edges(g, window, cells, short)
    if kind == "big":        # past a 32-bit port's small ints (2**30) and past 2**31 (not taken)
        return ((rng.signed(30 + rng.bits(2) % 3), rng.signed(31), rng.signed(24)) for _ in range(n))
    if kind in FLOATS:
        import gates_native
        bump = tail if kind == "tail" else gates_native.step
        first, n = SHORT_FLOATS if short else (0, n)
        return (s for i, s in enumerate(gates_native.samples(bump, first), first) if i < n)


def state(g):
    return list(g._st) + list(g._ring) + list(g.batches._due)


def checksum(h, values):
    for v in values:
        h = (h * 31 + (v & 0xFFFFFFF)) & MASK
    return h


def ending(g):
    """A checksum of the gates' state at a scenario's end: coverage counts, hist, fit, batches
    (iterated in place: a board's heap has no 6 KB block for them as one list)."""
    h = checksum(0, g.cov.counts)
    h = checksum(h, g.hist)
    h = checksum(h, (g.fit.n, g.removed, g.batches.cur) + tuple(g.batches._due))
    h = checksum(h, g.batches.counts)
    return checksum(h, [v & MASK for v in g.fit.sums()])


def same_sums(a, b):
    """The batches' float sums bit for bit (a float's own value: the same on one interpreter)."""
    for k in range(len(a)):
        if a[k] != b[k]:
            return False
    return len(a) == len(b)


def heap_locked(G, config, Calibration, Coverage, EllipsoidFit):
    """20 samples of a slow turn through native gates judging against a provisional calibration,
    with the heap locked (after 8 unlocked: cells with 3 samples, where the disturbance gate
    judges): what it raised, and how many it took (all 20, fewer than a residual batch's 32)."""
    import micropython
    import gates_native as GN
    cfg = config.defaults()
    g = G.Gates(cfg, EllipsoidFit(), Coverage(cfg["cells"], cfg["cell_cap"]), 2, 10.0, GN.OFFSET)
    g.use_provisional(Calibration(GN.matrix(), list(GN.OFFSET), GN.F), 20.0)
    pts = [s for _, s in zip(range(28), GN.samples())]
    for s in pts[:8]:
        g.sample(s[0], s[1], s[2])
    took = 0
    errors = []
    sample = g.sample
    micropython.heap_lock()
    try:
        for i in range(8, 28):
            s = pts[i]
            if sample(s[0], s[1], s[2]):
                took += 1
    except MemoryError:
        errors.append("MemoryError")
    finally:
        micropython.heap_unlock()
    return errors, took, g._exact is not None


def main(root, natmod=None, short=None):
    if short is None:
        short = sys.platform not in ("linux", "darwin", "win32")    # a board: rp2
    for folder in (root, root + "/device", root + "/tests/micropython", natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    import config
    import gates as G
    from lcg import Rand
    from shared.calibration import Calibration
    from shared.coverage import Coverage
    from shared.fit import EllipsoidFit

    native = G._NativeSample is not None
    slow = [0]

    def counting(g, sx, sy, sz):
        slow[0] += 1
        return G.Gates.sample(g, sx, sy, sz)

    def build(cfg, window, centre, nat):
        g = G.Gates(cfg, EllipsoidFit(), Coverage(cfg["cells"], cfg["cell_cap"]), window, 10.0, centre, native=nat)
        if nat:
            g.sample = G._NativeSample(g, counting)
        return g

    # first, on a fresh heap
    locked = heap_locked(G, config, Calibration, Coverage, EllipsoidFit) if native else None
    rng = Rand(19)
    differed = 0
    slows = []
    ref = twin = pair = end = None
    for s, (window, cells, cap, rate, centre, kind, n) in enumerate(SCENARIOS):
        n = n // 4 if short and kind not in FLOATS else n
        ref = twin = pair = end = None
        gc.collect()        # the last scenario's gates (a board's heap holds two pairs barely)
        cfg = config.defaults()
        cfg["cells"] = cells
        cfg["cell_cap"] = cap
        cfg["gate_rate_dps"] = rate
        if kind in FLOATS:
            import gates_native
            centre = gates_native.OFFSET
        # a board's integer scenarios run the native gates alone: CPython's pure-Python gates
        # checked the same verdicts and states sample by sample (the checksum); float sums are a
        # float's width, so those scenarios keep the reference on the board
        alone = native and short and kind not in FLOATS
        ref = build(cfg, window, centre, alone)
        twin = build(cfg, window, centre, True) if native and not alone else None
        pair = (ref, twin) if twin is not None else (ref,)
        if kind in FLOATS:
            cal = Calibration(gates_native.matrix(), list(centre), gates_native.F)
            for g in pair:
                g.use_provisional(cal, 20.0)
        if kind == "tau":
            for g in pair:
                g.lag = g.tau_sums = _Lag()
                g.hist_e = array("i", bytes(4 * 3 * G.HIST))
        slow[0] = 0
        h = 0
        for smp in stream(kind, n, rng, window, G, ref, cells, short):
            if smp is None:
                for g in pair:
                    g.break_chain()
                continue
            took = ref.sample(smp[0], smp[1], smp[2])
            st = state(ref)
            h = checksum(h, [2 if took else 1] + (st if kind not in FLOATS else []))
            if twin is not None and (twin.sample(smp[0], smp[1], smp[2]) != took or state(twin) != st):
                differed += 1
        slows.append(slow[0] if native else None)
        end = [ending(g) for g in pair]
        if len(end) > 1 and (end[0] != end[1] or not same_sums(ref.batches.sums, twin.batches.sums)):
            differed += 1
        print(json.dumps([s, ref.seen, ref.rej_rate, ref.rej_cap, ref.rej_dist, ref.removed, ref.fit.n,
                          checksum(h, [end[0]] if kind not in FLOATS else [])]))
    path = build(config.defaults(), 2, (0, 0, 0), True).path if native else "python"
    print(json.dumps({"path": path, "differed": differed, "slow": slows, "heap_locked": locked}))


if __name__ == "__main__" and len(sys.argv) > 2:    # a board without argv imports it and calls main()
    main(sys.argv[1], sys.argv[2] or None, len(sys.argv) > 3 and sys.argv[3] == "short")
