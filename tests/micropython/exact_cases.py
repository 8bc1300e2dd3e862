# The exact integer kernels' cases for native_linalg.py (beside it): shared/quadric.py's Problem.sums_at
# (moments.recentred) and Problem.exact, which linalgc.mpy runs in 512-bit words (device/native/exact_body.h)
# where it declines nothing, and hands back to Python (None) where a bound reaches 2**500.
# And quadric.frame_means, shifted and scaled (the problem's frame) and Problem.noise_gradient, the sums as floats in the frame (from the words there). Yields (kernel name, args):
# the Python's and the native results must be the same ints and floats (native_linalg.py compares a
# sums_at's ints, made from its words, and the next sums_at, exact and frame_means read the words).


class Sums:
    """A Problem's stand-in for sums that no samples make (sums_at reads .scaled, exact .n)."""

    def __init__(self, sums):
        self.scaled = sums
        self.n = sums[0]


def _int(rng, bits):
    """A random int of up to `bits` bits, either sign."""
    x = rng.bits(min(bits, 30))
    while bits > 30:
        bits -= 30
        x = (x << min(bits, 30)) | rng.bits(min(bits, 30))
    return -x if rng.bits(1) else x


def exact_cases(rng, short, sums_at, shifted):
    """sums_at, shifted: the installed Problem.sums_at and quadric.shifted (native where linalgc loads),
    which make the sums the next cases read."""
    from cortexm_core import sphere     # the benches' distorted sphere of 24-bit codes
    from shared.fit import EllipsoidFit
    from shared.quadric import _MEANS, FRAC, Problem
    n = 60 if short else 400
    pts = sphere(n)
    fit = EllipsoidFit()
    for k in range(0, 3 * n, 3):
        fit.add(pts[k], pts[k + 1], pts[k + 2])
    pb = Problem(fit.sums(), float)
    one = 1 << FRAC
    # the problem's frame: the sums about its centre, then scaled by powers of two (3: Python's)
    for centre in (pb.centre, [0, 0, 0], [_int(rng, 24) for _ in range(3)], [_int(rng, 70) for _ in range(3)]):
        yield "shifted", (fit.sums(), 1, centre)
    u = shifted(fit.sums(), 1, pb.centre)
    for scale in (1, 2, 1 << 17, 1 << 40, 1 << 120, 3):
        yield "scaled", (u, scale)
    # centres: none, small steps, an iteration's (~2**40), near the 64-bit limit, past it (declined)
    for bits in (0, 3, 12, 30, 41, 45, 62, 63, 64, 70) if not short else (0, 12, 41, 70):
        for r in range(1 if short else 3):
            f = [_int(rng, bits) for _ in range(3)]
            if r == 1:
                f[rng.bits(2) % 3] = 0                 # an axis the centre does not move along
            yield "sums_at", (pb, f, None)
            s = sums_at(pb, f, None)
            g = [f[i] + _int(rng, min(bits, 36)) for i in range(3)]
            yield "sums_at", (pb, g, (s, f))           # from the sums of a state nearby (its words)
            for abits in (40, 41, 62, 63, 64, 70) if not short else (41, 70):
                a = [one + _int(rng, abits - 2) for _ in range(3)] + [_int(rng, abits) for _ in range(3)]
                yield "exact", (pb, s, a)
            yield "noise_gradient", (pb, s, [1.0, 1.1, 0.9, 0.01, -0.02, 0.03])
            yield "frame_means", (s, _MEANS, float)
            yield "frame_means", (s, range(1, 10), float)
    # sums no samples make, from small to past 2**500: declined where a result could reach it
    for top in (8, 100, 300, 380, 440, 499, 500, 501, 700):
        fake = Sums([1 + rng.bits(20)] + [_int(rng, top - rng.bits(3)) for _ in range(34)])
        for cbits in (0, 1, 20, 60):
            f = [_int(rng, cbits) for _ in range(3)]
            yield "sums_at", (fake, f, None)
            s = sums_at(fake, f, None)
            yield "exact", (fake, s, [_int(rng, 41) for _ in range(6)])
            yield "frame_means", (s, range(35), float)     # small ones under a float's range, big ones past it
    yield "exact", (pb, sums_at(pb, [0, 0, 0], None), [one, one, one, 0, 0, 0.5])     # a float: Python's
    # the sums of a few random points of 0 to 63 bits about random centres: every bound's word count
    from shared.moments import ORDER
    for _ in range(6 if short else 40):
        bits = rng.bits(6)
        s = [0] * 35
        for _ in range(1 + rng.bits(3)):
            x, y, z = _int(rng, bits), _int(rng, bits), _int(rng, bits)
            for n, (i, j, k) in enumerate(ORDER):
                s[n] += x ** i * y ** j * z ** k
        points = Sums(s)
        yield "sums_at", (points, [_int(rng, rng.bits(6)) for _ in range(3)], None)
        s = sums_at(points, [_int(rng, rng.bits(6)) for _ in range(3)], None)
        yield "exact", (points, s, [_int(rng, rng.bits(6)) for _ in range(6)])
        yield "frame_means", (s, range(35), float)


def malformed_declined(native, words):
    """Whether linalgc declines (None) what moments and quadric never hand it: chains of length 0 or
    naming an index past the sums, a frame exponent past its range, index tables of another length."""
    from shared import moments
    ok = moments._CHAINS
    return all(r is None for r in (
        native.recentre(words, [1, 2, 3], [b"\x00", ok[1], ok[2]]),
        native.recentre(words, [1, 2, 3], [ok[0], bytes([2, 0, 35]), ok[2]]),
        native.recentre(words, [1, 2, 3], [ok[0], ok[1], bytes([5, 0, 1])]),
        native.frame_floats(words, b"\x04", moments.DEGREE, 1 << 20),
        native.frame_floats(words, b"\x23", moments.DEGREE, 40),
        native.exact(words, [1, 2, 3, 4, 5, 6], b"\x00" * 62, 120),
        native.exact_ints(words, b"\x23"),
    ))
