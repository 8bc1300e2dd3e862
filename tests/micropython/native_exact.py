# Runs under CPython (the pure-Python integers: the reference) and each MicroPython board
# (with fitsums' solver kernels, device/native/exact.h, where they load), from argv or
# main(root, natmod_folder): the kernels on random and adversarial integers against
# shared.moments and shared.quadric's pure-Python ones, then whole solves with the kernels
# and without them. Prints one JSON line: the path, the kernels' integers as decimal
# strings, one line per case (the same on every interpreter), then one JSON line: the
# mismatches found here, how many cases the words took, and the solves' floats.
import gc
import json
import sys

CASES = 60


def _lcg(seed):
    state = [seed]

    def bits(n):
        out = 0
        for _ in range((n + 29) // 30):
            state[0] = (1103515245 * state[0] + 12345) & 0x7FFFFFFF
            out = (out << 30) | (state[0] >> 1)
        return out & ((1 << n) - 1) if n else 0
    return bits


def _signed(bits, n):
    v = bits(n)
    return -v if bits(1) else v


def _sums(bits, case):
    """35 sums: random sizes up to 250 bits, or (some cases) the words' extremes."""
    top = 319
    out = []
    for k in range(35):
        if case % 7 == 3 and k % 5 == 0:
            out.append((1 << top) - 1 - bits(3) if bits(1) else -(1 << top) + bits(3))   # at the edge
        elif case % 7 == 5:
            out.append(_signed(bits, 200 + bits(6)))                                  # big: products overflow
        elif case % 7 == 6:
            out.append(_signed(bits, 300) + (1 << 318) * (1 - 2 * bits(1)))          # x 3: just past the words
        else:
            out.append(_signed(bits, bits(8)))
    return out


def _centre(bits, case):
    if case % 7 == 6:
        return [3, -3, 2]
    if case % 5 == 0:
        return [0, _signed(bits, 20), 0]                      # one axis only
    if case % 5 == 1:
        return [_signed(bits, 63), _signed(bits, 40), _signed(bits, 62)]     # past 32-bit small ints
    if case % 5 == 2:
        return [1 << 63, 0, -(1 << 63)]                       # past the 64-bit words: the ints
    return [_signed(bits, bits(5)) for _ in range(3)]


def _sphere(n, squash):
    import math
    seed = 7
    for _ in range(n):
        seed = (seed * 1103515245 + 12345) & 0x7FFFFFFF
        c = squash * (2 * (seed / 2147483648.0) - 1)
        seed = (seed * 1103515245 + 12345) & 0x7FFFFFFF
        p = 2 * math.pi * (seed / 2147483648.0)
        s = math.sqrt(1 - c * c)
        x, y, z = 5e6 * s * math.cos(p), 5e6 * s * math.sin(p), 5e6 * c
        yield int(1.004 * x + 0.01 * y + 30000), int(0.997 * y + 20000), int(1.001 * z - 0.015 * x - 10000)


def _cal(cal):
    return [repr(x) for row in cal.matrix for x in row] + [repr(x) for x in cal.offset] + [repr(cal.field)] + \
        [repr(cal.diagnostics.get(k)) for k in ("iterations", "rms", "predicted_error", "mode", "gains")]


def _edges():
    """Powers of two and their neighbours (where |x| and ~x differ in length) and the words' ends."""
    out = [0, -(1 << 319), (1 << 319) - 1]
    for k in (0, 1, 29, 30, 31, 32, 52, 53, 54, 63, 64, 65, 100, 200, 318):
        for d in (-1, 0, 1):
            out.append((1 << k) + d)
            out.append(-(1 << k) + d)
    return out


def _floats_differ(pb, moments, solvewords, sums, exponents):
    value = pb.floats(solvewords.pack(sums))
    return [[str(sums[i]), e] for i in range(35) for e in exponents
            if repr(value(i, e)) != repr(moments.to_float(sums[i], e))]


def kernels(moments, quadric, solvewords, native):
    """Each case's integers (printed, one line a case), the mismatches and counts:
    recentre, exact and the floats on CASES random cases."""
    bits = _lcg(5)
    from shared.fit import EllipsoidFit
    f = EllipsoidFit()
    for x, y, z in _sphere(200, 1.0):
        f.add(x, y, z)
    pb = quadric.Problem(f.sums(), float)
    bad = []
    count = {"recentre": 0, "exact": 0}
    for case in range(CASES):
        gc.collect()                        # a board's heap: the big ints leave it fragmented
        s = _sums(bits, case)
        c = _centre(bits, case)
        ref = moments.recentred(s, c)
        a = [_signed(bits, 30 + bits(5)) for _ in range(6)]
        if case % 9 == 4:
            a[4] = (1 << 63) - 1            # 2 a_4 passes 64 bits: the ints
        # exact() on sums of the solver's sizes (degree 4 ~ 2^(160 + log2 n)), which fit the
        # words, and on the sums above, most of which do not
        small = [x >> (bits(7) + 60) for x in s]
        line = [str(x) for x in ref]
        for sums in (small, s):
            ex = pb.exact(sums, a)
            line += [str(x) for x in ex[0] + ex[1] + [ex[2]]]
            if native:
                nat = solvewords.exact(solvewords.pack(sums), a, pb.n, quadric._TABLES)
                if nat is not None:
                    count["exact"] += 1
                    if list(nat) != list(ex):
                        bad.append(["exact", case])
                if list(pb.exact(solvewords.pack(sums), a)) != list(ex):
                    bad.append(["Problem.exact", case])
        if native:
            words = solvewords.pack(s)
            out = solvewords.recentre(words, c)
            if out is not None:
                count["recentre"] += 1
                if solvewords.unpack(out) != ref:
                    bad.append(["recentre", case])
            if solvewords.unpack(words) != s:
                bad.append(["pack", case])
            at = pb.sums_at(c, (words, [0, 0, 0]))      # words, or the ints where they do not fit
            if (solvewords.unpack(at) if type(at) is bytearray else at) != ref:
                bad.append(["sums_at", case])
            bad += _floats_differ(pb, moments, solvewords, s, (0, -80, -160))
        # one line per case (a board's heap holds no JSON of them all)
        print(json.dumps(line))
    gc.collect()
    if native:
        # a product just past the words (3 x 2^318) into a sum of the other sign, the one step of
        # the chain y^3, x y^3: the wrapped result looks in range, only the product's check sees it
        for sign in (1, -1):
            s = [0] * 35
            s[moments.INDEX[(0, 3, 0)]] = sign * ((1 << 318) + 5)
            s[moments.INDEX[(1, 3, 0)]] = -sign * ((1 << 318) + 7)
            out = solvewords.recentre(solvewords.pack(s), [3, 0, 0])
            if out is not None and solvewords.unpack(out) != moments.recentred(s, [3, 0, 0]):
                bad.append(["recentre past the words", sign])
        edges = _edges()
        for at in range(0, len(edges), 35):
            bad += _floats_differ(pb, moments, solvewords, (edges[at:at + 35] + [0] * 35)[:35], (0, -300))
    return bad, count


def solves(fit_module, solvewords, native):
    """Each case's calibration, with the kernels where they run and with the ints: (with, without)."""
    from shared.calibration import Calibration
    out = []
    for squash, n in ((1.0, 400), (0.4, 300)):
        f = fit_module.EllipsoidFit()
        for x, y, z in _sphere(n, squash):
            f.add(x, y, z)
        row = []
        keep = solvewords.fitsums
        for on in (True, False):
            solvewords.fitsums = keep if on else None
            try:
                cal = f.solve(scale=0.01)
                prior = Calibration(cal.matrix, [cal.offset[0] + 700.0, cal.offset[1] - 500.0, cal.offset[2] + 300.0],
                                    cal.field, {"predicted_error": cal.diagnostics["predicted_error"]})
                quick = f.solve(scale=0.01, prior=prior, refuse_worse=False)
                row.append(_cal(cal) + _cal(quick))
            except Exception as exc:      # FitError: a difference too
                row.append([repr(exc)])
        solvewords.fitsums = keep
        out.append(row)
    return out


def main(root, natmod_folder):
    if natmod_folder:
        sys.path.insert(0, natmod_folder)
    sys.path.insert(0, root)
    from shared import fit, moments, quadric, solvewords
    native = solvewords.available(quadric.FRAC)
    bad, count = kernels(moments, quadric, solvewords, native)
    both = solves(fit, solvewords, native)
    print(json.dumps({"path": "native" if native else "python", "count": count, "bad": bad,
                      "solves": [row[0] for row in both], "same": [row[0] == row[1] for row in both]}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "")
