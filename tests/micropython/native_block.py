# Runs under each MicroPython board with fitsums.block (tests/test_native_block.py), from argv or
# main(root, natmod_folder, cases): a block's numbers in C (device/native/block.h) against the
# pure-Python way device/survey.py's Output._numbers takes (protocol.hundredths, the correction's
# ExactCorrection._correct, (fs + 2^7 n) // (2^8 n)) on the same words, from a fixed 32-bit LCG
# (not `random`): sums of every width up to and past the words (2^31 for h_c, 2^47, the 64-bit
# ends), negative ones (floor division), |h_c| sums past a small int and negative, blocks of 1 to
# 2^16 - 1 samples, windows of 1 to 64, divisors past 2^22, values not a list of 12, the fixed
# arguments not a tuple of four.
# Prints one JSON line: how many cases, how many fitsums.block should answer (every sum and
# number within what block.h says it takes, every result a small int under 2^30), how many it
# answered, how many of those differ from Python's (values or the t sum), how many it declined
# that it should have answered, answered that it should have declined, left the words or the
# values other than block.h says (restarted, or untouched).
import json
import sys
from array import array


def main(root, natmod=None, cases=400):
    for folder in (root, root + "/device", root + "/tests/micropython", natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    from lcg import Rand
    from protocol import hundredths
    from shared.calibration import Calibration
    from shared.fixedpoint import ExactCorrection
    try:
        from fitsums import block
    except (ImportError, ValueError):        # CPython, a board without fitsums.mpy, CircuitPython
        block = None

    rng = Rand(47)
    cals = [Calibration([[0.0144, 0.0001, 0.0], [0.0, 0.0145, 0.0], [0.0, 0.0, 0.0143]], [100.0, -200.0, 50.0], 48000.0),
            Calibration([[1.5, -0.2, 0.1], [0.0, 1.4, 0.3], [0.0, 0.0, 1.6]], [-31000.5, 12000.25, 900.0], 48000.0)]
    edges = (0, 1, -1, 99, -99, 100, -100, (1 << 23) - 1, -(1 << 23), (1 << 30) - 1, -(1 << 30), (1 << 31) - 1,
             -(1 << 31) + 1, 1 << 31, (1 << 47) - 1, -(1 << 47) + 1, 1 << 47, (1 << 63) - 1, -(1 << 63))

    def number(wide):
        if rng.bits(3) == 0:
            return edges[rng.bits(8) % len(edges)]
        v = rng.bits(rng.bits(6) % wide)
        return -v if rng.bits(1) else v

    def limbs(v):
        u = v & 0xFFFFFFFFFFFFFFFF
        return [(u >> s) & 0xFFFF for s in (0, 16, 32, 48)]

    counts = {"cases": 0, "expected": 0, "answered": 0, "mismatched": 0, "missed": 0, "wrongly": 0, "untidy": 0}
    for i in range(cases):
        kind = i % 5
        n = (10, 1, 1 + rng.bits(16) % 65535, 10, 100)[kind]
        window = 1 + rng.bits(6) % 64
        d = n * window
        cal_i = rng.bits(1)
        ex = ExactCorrection(cals[cal_i], d)
        # the sums: a block's of codes under 2^24 mostly, any width at times
        wide = 56 if kind == 3 else 34
        s = [number(wide) for _ in range(4)] + [rng.bits(rng.bits(6) % 52)]
        if kind == 3 and rng.bits(1):
            s[4] = -s[4]
        if kind < 3:     # sums a real block has: codes under 2^20 (a field's), 2^23 (full scale); |h_c| a field's
            b = 19 if kind == 0 else 23
            s = [v % (2 * d << b) - (d << b) for v in s[:4]] + [s[4] % (n << 40)]
        words = array("H", [0] * 86)
        for j in range(5):
            words[4 * j:4 * j + 4] = array("H", limbs(s[j]))
        words[20] = 0
        values = [1, 0, b"", -7, -7, -7, b"", b"", -7, -7, -7, -7]
        restart = rng.bits(1) == 1
        how = (ex._native, n, d, restart)
        arg = values        # at times a list of 13, a tuple, or the fixed ones three: declined
        if kind == 4 and rng.bits(2) == 0:
            k = rng.bits(8) % 3
            if k == 2:
                how = how[:3]
            else:
                arg = values + [0] if k else tuple(values)
        counts["cases"] += 1
        # Python's numbers (Output._numbers), and whether block.h takes them
        ref = [hundredths(s[0], d), hundredths(s[1], d), hundredths(s[2], d)]
        ref += list(ex._correct(s[0], s[1], s[2])) + [(s[4] + (n << 7)) // (n << 8), s[3]]
        ours = (arg is values and len(how) == 4 and ex._native is not None and d < 1 << 22 and
                all(-(1 << 47) < v < 1 << 47 for v in s) and all(-(1 << 31) < v < 1 << 31 for v in s[:3]) and
                s[4] >= 0 and all(abs(v) // d < 1 << 23 for v in s[:3]) and
                all(-(1 << 30) <= v < 1 << 30 for v in ref))
        counts["expected"] += ours
        if block is None or ex._native is None:
            continue
        before = bytes(words)
        st = block(words, how, arg)
        if st is None:
            counts["missed"] += ours
            counts["untidy"] += bytes(words) != before or values[3] != -7
            continue
        counts["answered"] += 1
        counts["wrongly"] += not ours
        got = [values[3], values[4], values[5], values[8], values[9], values[10], values[11], st]
        counts["mismatched"] += got != [ref[0], ref[1], ref[2], ref[3], ref[4], ref[5], ref[6], ref[7]]
        want = bytes(array("H", [0] * 20 + [n])) if restart else before[:42]
        counts["untidy"] += bytes(words)[:42] != want or bytes(words)[42:] != before[42:]
    counts["path"] = "python" if block is None else "native"
    print(json.dumps(counts))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else None, int(sys.argv[3]) if len(sys.argv) > 3 else 1500)
