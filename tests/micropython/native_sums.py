# Runs under CPython (the pure-Python sums: the reference) and each MicroPython board
# (with the native module fitsums where it loads), from argv or main(root, natmod_folder):
# puts the folder holding fitsums.mpy and the repository root on sys.path, feeds
# shared.fit.EllipsoidFit the same codes everywhere (a fixed 32-bit LCG, not `random`,
# whose generator differs between runtimes) and prints one JSON line: which path
# summed them and every case's 35 sums as decimal strings.
import json
import sys

TOP = 1 << 23          # 24-bit ADC codes: [-TOP, TOP)


def _codes(seed, count):
    state = seed
    for _ in range(count):
        out = []
        for _axis in range(3):
            state = (1103515245 * state + 12345) & 0xFFFFFFFF
            out.append((state >> 7) - TOP)          # 25 bits of the state, balanced
        yield out


def _extremes(put):
    edges = (-TOP, TOP - 1, -TOP + 1, 0, 1, -1, TOP >> 1)
    for x in edges:
        for y in edges:
            for z in edges:
                put(x, y, z)
    for _ in range(3000):
        put(-TOP, -TOP, TOP - 1)
        put(TOP - 1, -TOP, -TOP)


def cases(fit):
    E = fit.EllipsoidFit
    out = []
    # random codes, then a tenth of them removed
    f = E()
    kept = []
    for i, (x, y, z) in enumerate(_codes(1, 1500)):
        f.add(x, y, z)
        if i % 10 == 0:
            kept.append((x, y, z))
    for x, y, z in kept:
        f.remove(x, y, z)
    out.append([f.n])           # the count before the words are drained
    out.append(f.sums())
    # the extremes in every combination, then a long run at full scale: x^4 alone
    # passes 2**64 at the first sample and 2**100 within the run
    f = E()
    _extremes(f.add)
    out.append(f.sums())
    # every sample removed again: all sums back to zero
    _extremes(f.remove)
    out.append(f.sums())
    # codes past the native words' 2**24 (and past a 32-bit port's small ints), bools,
    # interleaved with codes the native words take: both paths into the same sums
    f = E()
    wide = ((1 << 24) - 1, 1 << 24, -(1 << 24), -(1 << 24) + 1, 1 << 30, -(1 << 40), True, False)
    for i, (x, y, z) in enumerate(_codes(2, 200)):
        w = wide[i % len(wide)]
        f.add(x, w, z)
        f.add(w, y, -w)
        if i % 3 == 0:
            f.remove(w, y, -w)
    out.append(f.sums())
    # draining mid-stream (every 7 samples) with sums read in between, and a merge
    drain = fit._DRAIN
    fit._DRAIN = 7
    a, b = E(), E()
    for i, (x, y, z) in enumerate(_codes(3, 300)):
        (a if i % 2 else b).add(x, y, z)
        if i % 50 == 0:
            a.sums()
    fit._DRAIN = drain
    a.merge(b)
    out.append(a.sums())
    out.append(b.sums())
    # the first ten read every 32 samples, as the residual batches read them (only their words
    # drained), with removes and, in the second half, codes the words do not take (packs in use)
    f = E()
    for i, (x, y, z) in enumerate(_codes(4, 600)):
        f.add(x, y, (1 << 24) + i if i >= 300 and i % 5 == 0 else z)
        if i % 9 == 0:
            f.remove(x, y, z)
        if i % 32 == 31:
            low = f.low_sums()
            if i == 319:
                out.append(low)      # one of them kept: the Cortex-M3's heap holds no more
    out.append(f.sums())
    try:
        E().add(1.5, 2, 3)
        refused = None
    except TypeError as exc:
        refused = str(exc)
    return out, refused


def main(root, natmod=None):
    for folder in (root, natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    from shared import fit

    sums, refused = cases(fit)
    print(json.dumps({"path": fit.SUMS_PATH, "sums": [[str(v) for v in s] for s in sums], "refused": refused}))


if __name__ == "__main__" and len(sys.argv) > 2:    # a board without argv imports it and calls main()
    main(sys.argv[1], sys.argv[2] or None)
