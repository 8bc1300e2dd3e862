# Runs under CPython (Python's own `%` on the parts: the reference) and each MicroPython board (with
# fitsums.line where it loads), from argv or main(root, natmod_folder, cases): puts the folder
# holding fitsums.mpy, the repository's device/ and tests/micropython/ on sys.path and makes the
# same lines everywhere (a fixed 32-bit LCG, not `random`): the survey's data and raw events
# (device/protocol.py DATA_LINE, RAW_LINE) with random values, random formats of every conversion
# line.h reads (and %x and %5d, which it declines), numbers at the edges (0, +-1, the units, the
# small ints' and the words' limits), buffers too small, a value left over or missing. Each format
# is read as line.h reads it (kinds()): a fixed-point number is one value to fitsums.line and its
# parts to `%` (sign, whole, fraction as protocol.parts3 makes them). Prints each line as `%`
# makes it (or "error"), then one JSON line: how many cases, how many fitsums.line should answer
# (every conversion its own, every value an int under 2**32 and a small int here, or bytes, the
# line within the buffer), how many it answered, how many of its lines differ from `%`'s here, and
# how many it answered that it should have declined.
import json
import sys

CHOICES = (b"true", b"false", b"null", b"25.37", b"-3.46", b"",
           b'"temperature 45.1 C outside the compensated 10.0..30.0 C"')
LITERALS = (b"{", b'"a": ', b", ", b"]", b"[", b"}", b"x" * 40, b".", b"-", b"0")
TOKENS = (b"%d", b"%s", b"%s%d.%02d", b"%s%d.%03d", b"%d.%03d", b"%d.%02d", b"%s%d.%01d", b"%s%d.%09d",
          b"%d", b"%s")
ODD = (b"%x", b"%5d")       # Python's, not line.h's


def digit(b):
    return len(b) == 1 and 49 <= b[0] <= 57      # 1-9


def kinds(fmt):
    """The conversions as line.h reads them: ("S", N) signed fixed point of N places (%s%d.%0Nd),
    ("U", N) not negative (%d.%0Nd), ("d", 0), ("s", 0), ("?", 0) any other (% and one character)."""
    out = []
    i = fmt.find(b"%")
    while i >= 0:
        r = fmt[i + 1:i + 9]
        if r[:6] == b"s%d.%0" and digit(r[6:7]) and r[7:8] == b"d":
            out.append(("S", r[6] - 48))
            i += 9
        elif r[:4] == b"d.%0" and digit(r[4:5]) and r[5:6] == b"d":
            out.append(("U", r[4] - 48))
            i += 7
        else:
            out.append((r[:1].decode(), 0) if r[:1] in (b"d", b"s") else ("?", 0))
            i += 2
        i = fmt.find(b"%", i)
    return out


def parts(ks, values):
    """`%`'s values: each fixed-point number as its parts."""
    out = []
    for (k, n), v in zip(ks, values):
        u = 10 ** n
        if k == "S":
            m = -v if v < 0 else v
            out += [b"-" if v < 0 else b"", m // u, m % u]
        elif k == "U":
            out += [v // u, v % u]
        else:
            out.append(v)
    return tuple(out)


def main(root, natmod=None, cases=600):
    for folder in (root, root + "/device", root + "/tests/micropython", natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    from lcg import Rand
    from protocol import DATA_LINE, RAW_LINE
    try:
        from fitsums import line
    except (ImportError, ValueError):        # CPython, a board without fitsums.mpy, CircuitPython (ValueError)
        line = None

    small = 1 << 30 if sys.maxsize < (1 << 32) else 1 << 62     # small ints: |v| < small (py/smallint.h)
    limit = min(small, 1 << 32)             # the numbers line.h writes
    edges = (0, 1, -1, 5, -5, 99, -99, 100, -100, 101, 999, -999, 1000, -1000, 1001, (1 << 30) - 1,
             -(1 << 30) + 1, 1 << 30, -(1 << 30), (1 << 32) - 1, -(1 << 32) + 1, 1 << 32, (1 << 40) + 3)
    rng = Rand(23)

    def number():
        if rng.bits(3) == 0:
            return edges[rng.bits(8) % len(edges)]
        v = rng.bits(rng.bits(6) % 36)
        return -v if rng.bits(1) else v

    def case(i):
        """(format, values to fitsums.line, values to `%`, buffer size, whether line.h takes it)."""
        kind = i % 8
        if kind < 4:                        # the events as survey.py makes them
            fmt = RAW_LINE if kind == 3 else DATA_LINE
        else:
            out = []
            for _ in range(rng.bits(4) % 12):
                if rng.bits(1):
                    out.append(LITERALS[rng.bits(8) % len(LITERALS)])
                out.append(ODD[rng.bits(1)] if kind == 7 and rng.bits(3) == 0 else TOKENS[rng.bits(8) % len(TOKENS)])
            fmt = b"".join(out)
        ks = kinds(fmt)
        values = [CHOICES[rng.bits(8) % len(CHOICES)] if k == "s" else number() for k, _n in ks]
        ours = True
        for (k, _n), v in zip(ks, values):
            ours = ours and k != "?" and (k == "s" or -limit < v < limit) and (k != "U" or v >= 0)
        py = list(parts(ks, values))
        if kind == 7 and rng.bits(1):       # a value left over, or one missing
            if rng.bits(1) or not values:
                values.append(7)
                py.append(7)
            else:
                values.pop()
                py = list(parts(ks, values))
            ours = False
        return fmt, tuple(values), tuple(py), 320 if kind < 6 else rng.bits(7), ours

    counts = {"cases": 0, "expected": 0, "answered": 0, "mismatched": 0, "wrongly": 0}
    for i in range(cases):
        fmt, values, py, size, ours = case(i)
        try:
            ref = fmt % py
            print(ref.decode().rstrip("\n"))
        except Exception:  # noqa: BLE001 - a value missing or left over
            ref = None
            print("error")
        ours = ours and ref is not None and len(ref) <= size
        counts["cases"] += 1
        counts["expected"] += ours
        if line is not None:
            buf = bytearray(size)
            n = line(buf, fmt, values)
            if n is not None:
                counts["answered"] += 1
                counts["mismatched"] += ref is None or bytes(buf[:n]) != ref
                counts["wrongly"] += not ours
    counts["path"] = "python" if line is None else "native"
    print(json.dumps(counts))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else None, int(sys.argv[3]) if len(sys.argv) > 3 else 600)
