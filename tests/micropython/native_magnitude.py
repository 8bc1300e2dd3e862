# Runs under CPython (the pure-Python |h_c|: the reference) and each MicroPython board (with
# fitsums.magnitude where it loads), from argv or main(root, natmod_folder): puts the folder
# holding fitsums.mpy and the repository root on sys.path, feeds
# shared.fixedpoint.ExactCorrection.magnitude the same corrections and sums everywhere (a fixed
# 32-bit LCG, not `random`; calibrations as integer pairs, so no float's width enters) and
# prints every |h_c| as a decimal line (not kept: kept, they scatter over the heap and leave no
# block for a long list), then one JSON line: the corrections' paths, how many
# calls the native function answered against how many fit its words (ExactCorrection's own
# numbers: the native answer is compared with the pure-Python method on the same interpreter
# too), and the native calls made for corrections whose numbers do not fit (none allowed).
# With every |h_c| the same call's fitsums.correct (h_c) and fitsums.survey (two samples into a
# block's words: the sums, |h_c| and the count) against the pure methods, and how many of the
# calls that fit their words each answered.
import json
import sys

TOP = 1 << 23              # 24-bit ADC codes: [-TOP, TOP)
SUM = 1 << 31              # the native words' sums: |s| < SUM, and small ints (2**30 on a 32-bit port)
H = 1 << 62                # and their h_i: |h_i| < H


class Pairs:
    """A calibration as ExactCorrection reads it: M and b as exact (m, e) pairs, m 2**e."""
    tempco = None

    def __init__(self, m, b):
        self.pairs = (m, b)

    def exact_pairs(self):
        return self.pairs


def calibrations():
    """(name, Pairs, windows): realistic, adversarial, coefficients near the words' 2**63, and
    two whose numbers do not fit (a coefficient past 2**63, an offset past 2**31)."""
    real = Pairs([[(61952125, -32), (-184467, -32), (95231, -32)], [(-184467, -32), (62100001, -32), (-40961, -32)],
                  [(95231, -32), (-40961, -32), (61711111, -32)]],
                 [(1234567891, -8), (-987654321, -10), (15, -1)])
    adv = Pairs([[(35184372088831, -45), (-5629499534213, -45), (7036874417767, -45)],
                 [(-5629499534213, -45), (98516241848321, -45), (-3518437208883, -45)],
                 [(7036874417767, -45), (-3518437208883, -45), (61572651155457, -45)]],
                [(-(TOP - 3) * (1 << 20) + 12345, -20), ((TOP - 2) * (1 << 20) + 524287, -20), (-8796093022207, -20)])
    top = Pairs([[(8589934591, -17), (-3, 0), (1, 0)], [(0, 0), (-8589934589, -17), (0, 0)],
                 [(5, 0), (0, 0), (8589934583, -17)]],
                [(3, 0), (-1, -1), (0, 0)])
    wide_c = Pairs([[(1, 20), (0, 0), (0, 0)], [(0, 0), (1, -6), (0, 0)], [(0, 0), (0, 0), (1, -6)]],
                   [(0, 0), (0, 0), (0, 0)])
    wide_w = Pairs([[(1, -6), (0, 0), (0, 0)], [(0, 0), (1, -6), (0, 0)], [(0, 0), (0, 0), (1, -6)]],
                   [(1, 33), (0, 0), (0, 0)])
    return [("real", real, (1, 2, 10, 20, 64)), ("adversarial", adv, (1, 2, 64)), ("top", top, (1, 2)),
            ("wide_c", wide_c, (1,)), ("wide_w", wide_w, (1,))]


def window_sums(rng, n):
    """Sums of n codes: the +-2**23 corners, random ones over the range, and sums past the words."""
    out = []
    edges = (-TOP * n, (TOP - 1) * n, 0, 1, -1)
    for x in edges:
        for y in edges:
            for z in edges[:2]:
                out.append((x, y, z))
    for _ in range(24):
        out.append((rng.signed(24) * n // 2, rng.signed(24) * n // 2, rng.signed(24) * n // 2))
    out.append((SUM - 1, -SUM + 1, 0))
    out.append((SUM, 0, 0))
    out.append((0, -SUM, 5))
    out.append((1 << 40, 0, 0))
    return out


def target_flat(h):
    """Numbers (and sums) whose h is exactly h, |h_i| < 2**63: c = 2**60 I, w = 0,
    s_i = h_i >> 32, k_i = -((h_i mod 2**32) << 28), d = 28: floor((c s_i - k_i) / 2**28) = h_i."""
    c = 1 << 60
    k = [-((v & 0xFFFFFFFF) << 28) for v in h]
    return (0, 0, 0, c, 0, 0, 0, c, 0, 0, 0, c, k[0], k[1], k[2], 28), tuple(v >> 32 for v in h)


def crafted(rng):
    """(flat, sums): squares at and beside perfect squares up to 3 * 2**124, h at the 2**62
    edge, random numbers over the words' whole range, and every number at its extreme."""
    out = []
    bs = [1, 2, 3, 1 << 15, (1 << 30) - 1, 1518500249, 1518500250] + [rng.bits(30) for _ in range(12)]
    for b in bs:
        r = 2 * b * b + 1
        for h in ((2 * b * b, 2 * b, 0), (r, 0, 0), (r, 1, 0), (0, -r, 1), (-2 * b * b, 0, -2 * b)):
            if max(abs(v) for v in h) < (H << 1):
                out.append(target_flat(h))
    r60 = 1 << 60        # q = 2**120: where fitsums' root leaves one 64-bit remainder for 128-bit words
    for h in ((H - 1, H - 1, H - 1), (-H + 1, H - 1, -H + 1), (H, 0, 0), (0, -H, 0), (-H - 1, 0, 0),
              (H - 1, 0, 0), (-H, 1, 1), (3037000499, 3037000499, 3037000500),
              (r60 - 1, 0, 0), (r60, 0, 0), (0, -r60, 1), (r60 - 1, 1 << 31, 1), (1 << 47, 0, 0), ((1 << 47) - 1, 1, 0)):
        out.append(target_flat(h))
    for _ in range(120):
        d = (1, 13, 28, 31)[rng.bits(2)]
        eb = rng.bits(5) + 1
        cb = min(63, 60 + d - eb)
        flat = tuple([rng.signed(31) for _ in range(3)] + [rng.signed(rng.bits(6) % cb + 1) for _ in range(9)] +
                     [rng.signed(rng.bits(6) % 64) for _ in range(3)] + [d])
        sums = tuple(flat[j] + rng.signed(eb) for j in range(3))
        out.append((flat, tuple(max(-SUM + 1, min(SUM - 1, s)) for s in sums)))
    m63 = (1 << 63) - 1
    m31 = SUM - 1
    for sw in (1, -1):
        for sc in (1, -1):
            for sk in (1, -1):
                flat = (sw * m31, -sw * m31, sw * m31) + (sc * m63, -sc * m63, sc * m63) * 3 + (sk * m63,) * 3
                out.append((flat + (31,), (-sw * m31, sw * m31, -sw * m31)))
                out.append((flat + (31,), (sw * m31 - sw, -sw * m31 + sw, sw * m31 - sw)))
                out.append((flat + (1,), (sw * m31, -sw * m31, sw * m31)))
    return out


def main(root, natmod=None):
    for folder in (root, root + "/tests/micropython", natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    from array import array

    from lcg import Rand as Lcg
    from shared import fixedpoint as fp
    try:
        from fitsums import survey
    except (ImportError, ValueError):        # CPython, a board without fitsums.mpy, CircuitPython (ValueError)
        survey = None

    class Rand(Lcg):
        def signed(self, n):
            """+-v, v < 2**n, its sign from one more bit (this script's draw; lcg's signed is uniform)."""
            v = self.bits(n)
            return -v if self.bits(1) else v

    counts = [0, 0]                          # native calls, native answers
    real = fp._native_magnitude
    if real is not None:
        def counting(numbers, sx, sy, sz):
            counts[0] += 1
            f = real(numbers, sx, sy, sz)
            if f is not None:
                counts[1] += 1
            return f
        fp._native_magnitude = counting      # the method looks the global up at each call

    E = fp.ExactCorrection
    rng = Rand(19)
    paths = []
    expected = 0                             # calls whose numbers and sums fit the words
    lo, hi = (-(1 << 30), 1 << 30) if sys.maxsize < (1 << 32) else (-SUM + 1, SUM)   # sums: lo <= s < hi
    mismatched = 0                           # answers that differ from the pure method here
    misfit_calls = 0                         # native calls for corrections that do not fit
    more = {"correct": 0, "correct_expected": 0, "survey": 0, "survey_expected": 0}

    w = array("H", [0] * 86)                 # fitsums.survey's words (hc.h SURVEY_LIMBS)

    def words_of(w):
        """fitsums.survey's words (hc.h): the five sums (64-bit two's complements) and LEFT."""
        out = []
        for i in range(0, 20, 4):
            v = w[i] | (w[i + 1] << 16) | (w[i + 2] << 32) | (w[i + 3] << 48)
            out.append(v - (1 << 64) if v >> 63 else v)
        return out + [w[20]]

    def natives(ex, sx, sy, sz, fit, f):
        """fitsums.correct and fitsums.survey beside the pure methods: the mismatches."""
        bad = 0
        b = None if fp._native_correct is None or ex._native is None else fp._native_correct(ex._native, sx, sy, sz)
        ref = E._correct(ex, sx, sy, sz)
        if fit and max(abs(v) for v in ref) < 1 << 30:
            more["correct_expected"] += 1
            more["correct"] += b is not None
        bad += ex.correct(sx, sy, sz) != ref or (b is not None and b != ref)
        if survey is None or ex._native is None:
            return bad
        for i in range(22):                  # the words (one array: a small heap fragments)
            w[i] = 0
        for i in range(64):
            w[22 + i] = ex._native[i]
        w[20] = 2                            # LEFT 2, |h_c| summed with the numbers
        w[21] = 1
        r = survey(w, sx, sy, sz, sz)
        if fit and f is not None and f < 1 << 47:
            more["survey_expected"] += 1
        if r is None:
            return bad + (words_of(w) != [0] * 5 + [2])      # refused: nothing changed
        more["survey"] += 1
        bad += r is not False or words_of(w) != [sx, sy, sz, sz, f, 1]
        # a second sample without |h_c| (HAS_F 0: 0) completes the block; then the count refuses
        w[21] = 0
        r = survey(w, sy, sz, sx, -7)
        bad += r is not True or words_of(w) != [sx + sy, sy + sz, sz + sx, sz - 7, f, 0]
        return bad + (survey(w, 0, 0, 0, 0) is not None)

    def run(ex, sums):
        nonlocal expected, mismatched
        for sx, sy, sz in sums:
            top = max(abs(v) for v in ex._axes(sx, sy, sz))
            fit = ex._native is not None and lo <= sx < hi and lo <= sy < hi and lo <= sz < hi and top < H
            expected += fit
            if top >= 2 * H:
                # q >= 2**126: past what the pure method's float guess takes on every float width
                # (a float32's sqrt overflows at 2**128); the native function must refuse it
                if real is not None and ex._native is not None and real(ex._native, sx, sy, sz) is not None:
                    mismatched += 1
                mismatched += natives(ex, sx, sy, sz, False, None)
                print("-")
                continue
            got = ex.magnitude(sx, sy, sz)
            if got != E._magnitude(ex, sx, sy, sz) or not isinstance(got, int):
                mismatched += 1
            mismatched += natives(ex, sx, sy, sz, fit, got)
            print(got)

    for name, cal, windows in calibrations():
        for n in windows:
            ex = E(cal, n)
            paths.append(name + ":" + ex.path)
            before = counts[0]
            run(ex, window_sums(rng, n))
            if name.startswith("wide"):
                misfit_calls += counts[0] - before
    ex = E(calibrations()[0][1], 1)
    for flat, sums in crafted(rng):
        ex._flat = flat
        ex._native = fp.native_numbers(flat)
        run(ex, [sums])
    more.update({"path": "python" if real is None else "native", "paths": paths, "expected": expected,
                 "native": counts[1], "mismatched": mismatched, "misfit_calls": misfit_calls})
    print(json.dumps(more))


if __name__ == "__main__" and len(sys.argv) > 2:    # a board without argv imports it and calls main()
    main(sys.argv[1], sys.argv[2] or None)
