# Runs under CPython (shared/linalg.py's Python alone) and each MicroPython board (with linalgc.mpy
# where it loads), from argv or main(root, natmod_folder): puts the folder holding linalgc.mpy and
# the repository on sys.path, imports it as the firmware does at boot and installs it as a session
# does (shared/linalg_native.py), and calls cholesky, cho_solve, solve_spd, eigh3, normal_matrix and
# add_prior on the same inputs twice, through the native module and with the Python's own functions
# (linalg_native._PYTHON): the results must be the same bits (each float packed as the interpreter's
# own width; add_prior's h and g after it) and what raises must raise the same exception. Inputs from a fixed 32-bit LCG (lcg.py beside it): symmetric
# positive definite matrices of 1 to 12 rows (random, badly scaled by powers of two, nearly
# singular, with entries from 2**-60 to 2**60), indefinite and singular ones, lower triangles with a
# zero on the diagonal, 3x3 symmetric matrices for eigh3 (random, nearly diagonal: the tiny-angle
# branch, already diagonal, equal eigenvalues, huge entries whose products overflow, tiny ones),
# power sums and quadrics for normal_matrix and prior rows for add_prior (random, zeros of both
# signs, overflowing), and what the native module must hand back to Python (ints among the floats,
# nan, inf, tuples, ragged rows, 13 rows, None where a sum is read, a list twice in h). Then whole solves (shared.fit: a full one, a provisional one, a quick
# re-calibration; not on the emulated boards, where every run is shorter) of a distorted sphere, native
# and not: the same calibration to the bit.
# Prints one JSON line: the path, the calls compared, those that differed, how many the native
# module answered itself, and the solves that differed.
import gc
import json
import math
import sys

FLOAT_CODE = "d" if 1.0 + 2.0 ** -40 != 1.0 else "f"


def flat(x, out):
    """Every number in x (nested lists and tuples), in order, appended to out."""
    if isinstance(x, (list, tuple)):
        for y in x:
            flat(y, out)
    else:
        out.append(x)
    return out


def bits(x):
    """x's floats as bytes of the interpreter's own width (one pack), anything else by repr."""
    import struct
    items = flat(x, [])
    if all(isinstance(v, float) for v in items):
        return struct.pack("<%d%s" % (len(items), FLOAT_CODE), *items)
    return repr(items).encode()


def fl(rng, lo=-20, hi=20):
    """A random float: a 24-bit mantissa times 2**e, e in lo..hi."""
    return math.ldexp(float(rng.signed(23)), rng.bits(8) % (hi - lo + 1) + lo - 23)


def spd(rng, n, scale_bits=0, eps=1.0):
    """B B^T + eps I, rows and columns scaled by 2**(+-scale_bits) at random."""
    b = [[fl(rng, -2, 2) for _ in range(n)] for _ in range(n)]
    a = [[sum(b[i][k] * b[j][k] for k in range(n)) + (eps if i == j else 0.0) for j in range(n)] for i in range(n)]
    if scale_bits:
        s = [math.ldexp(1.0, rng.bits(8) % (2 * scale_bits + 1) - scale_bits) for _ in range(n)]
        a = [[a[i][j] * s[i] * s[j] for j in range(n)] for i in range(n)]
    return a


def sym3(rng, lo, hi, off=1.0):
    a = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i, 3):
            x = fl(rng, lo, hi) * (1.0 if i == j else off)
            a[i][j] = x
            a[j][i] = x
    return a


def cases(rng, short):
    """(kernel name, args) to compare."""
    sizes = (1, 2, 3, 4, 6, 9, 12) if not short else (3, 9)
    reps = 1 if short else 6
    for n in sizes:
        for r in range(reps):
            for scale_bits, eps in ((0, 1.0), (20, 1.0), (60, 1.0), (0, 1e-7), (10, 0.0)):
                a = spd(rng, n, scale_bits, eps)
                b = [fl(rng) for _ in range(n)]
                yield "cholesky", (a,)
                yield "solve_spd", (a, b)
                try:
                    low = _python("cholesky", (a,))
                except ValueError:
                    continue
                yield "cho_solve", (low, b)
        bad = spd(rng, n)
        bad[n - 1][n - 1] = -bad[n - 1][n - 1]                   # indefinite
        yield "cholesky", (bad,)
        yield "solve_spd", (bad, [1.0] * n)
        zero = [[0.0] * n for _ in range(n)]
        yield "cholesky", (zero,)
        yield "solve_spd", (zero, [1.0] * n)
        low = [[fl(rng) if j <= i else 0.0 for j in range(n)] for i in range(n)]
        yield "cho_solve", (low, [fl(rng) for _ in range(n)])
        low[n // 2][n // 2] = 0.0                                 # ZeroDivisionError in Python
        yield "cho_solve", (low, [fl(rng) for _ in range(n)])
    for r in range(3 if short else 40):
        yield "eigh3", (sym3(rng, -8, 8),)
        yield "eigh3", (sym3(rng, -3, 3, 1e-7),)                 # the tiny-angle branch
        yield "eigh3", (sym3(rng, 30, 35),)                       # products past binary32's range
        yield "eigh3", (sym3(rng, -60, -40),)
        yield "eigh3", (sym3(rng, -2, 2, 0.0),)                   # diagonal already
    yield "eigh3", ([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],)
    yield "eigh3", ([[2.0, 1.0, 1.0], [1.0, 2.0, 1.0], [1.0, 1.0, 2.0]],)
    # what the native module hands back to Python: the same answers through it
    inf = float("inf")
    nan = inf - inf
    yield "cholesky", ([[4, 2], [2, 3]],)
    yield "cholesky", ([[4.0, 2.0], [2.0, inf]],)
    yield "cholesky", ([[nan, 2.0], [2.0, 3.0]],)
    yield "cholesky", (((4.0, 2.0), (2.0, 3.0)),)
    yield "cholesky", ([[4.0, 2.0], [2.0]],)
    yield "cholesky", (spd(rng, 13),)
    yield "cho_solve", ([[2.0, 0.0], [1.0, 3.0]], [1, 2.0])
    yield "cho_solve", ([[2.0, 0.0], [1.0, 3.0]], [1.0, 2.0, 3.0])
    yield "solve_spd", ([[4.0, 2.0], [2.0, 3.0]], [inf, 1.0])
    yield "solve_spd", ([[4.0, 2.0], [2.0, 3.0]], (1.0, 2.0))
    yield "eigh3", ([[1.0, 2.0], [2.0, 1.0]],)
    yield "eigh3", ([[1, 2, 0], [2, 1, 0], [0, 0, 5]],)
    yield from normal_cases(rng, short)
    from exact_cases import exact_cases
    from shared import quadric
    yield from exact_cases(rng, short, quadric.Problem.sums_at, quadric.shifted)


def sums35(rng, lo, hi):
    """normal_matrix's `mean`: floats at the power sums of degree 2..4 (storage indices 4..34), None below."""
    return [None] * 4 + [fl(rng, lo, hi) for _ in range(31)]


def prior_rows(rng, n, lo=-10, hi=10):
    """n rows of 9 floats, about half of them zeros of either sign (add_prior skips those columns)."""
    return [[(fl(rng, lo, hi) if rng.bits(1) else (0.0 if rng.bits(1) else -0.0)) for _ in range(9)] for _ in range(n)]


def normal_cases(rng, short):
    """(kernel name, args) for shared/quadric.py's normal_matrix and shared/iteration.py's add_prior."""
    for r in range(4 if short else 40):
        nf = float(rng.bits(12) + 12)
        yield "normal_matrix", (sums35(rng, -6, 6), sym3(rng, -3, 3), nf)
        yield "normal_matrix", (sums35(rng, -40, 40), sym3(rng, -40, 40), fl(rng, -30, 30))
        n = rng.bits(8) % 10 + 1
        h = [[fl(rng) for _ in range(9)] for _ in range(9)]
        yield "add_prior", (h, [fl(rng) for _ in range(9)], [fl(rng) for _ in range(n)], prior_rows(rng, n), fl(rng, -40, 0))
        yield "add_prior", (None, [fl(rng) for _ in range(9)], [fl(rng) for _ in range(n)], prior_rows(rng, n), fl(rng, -40, 0))
    inf = float("inf")
    big = sums35(rng, 120, 127)     # products past binary32's range (an infinity: Python's then)
    yield "normal_matrix", (big, sym3(rng, 100, 120), 1e-30)
    bad = sums35(rng, -6, 6)
    bad[20] = 3                    # an int: Python's
    yield "normal_matrix", (bad, sym3(rng, -3, 3), 100.0)
    bad = sums35(rng, -6, 6)
    bad[12] = None                 # TypeError in Python
    yield "normal_matrix", (bad, sym3(rng, -3, 3), 100.0)
    yield "normal_matrix", (sums35(rng, -6, 6)[:34], sym3(rng, -3, 3), 100.0)    # IndexError
    yield "normal_matrix", (sums35(rng, -6, 6), sym3(rng, -3, 3), 0.0)          # ZeroDivisionError
    rows = prior_rows(rng, 3)
    h = [[fl(rng) for _ in range(9)] for _ in range(9)]
    yield "add_prior", (h, [fl(rng) for _ in range(9)], [fl(rng) for _ in range(3)], rows, inf)
    yield "add_prior", (h, [fl(rng) for _ in range(9)], [fl(rng, 100, 120) for _ in range(3)], prior_rows(rng, 3, 100, 120), 1e30)
    yield "add_prior", (h, (1.0,) * 9, [1.0], prior_rows(rng, 1), 1.0)                  # a tuple g: TypeError
    yield "add_prior", (h, [1.0] * 9, [1.0, 2.0], prior_rows(rng, 1), 1.0)              # zip stops at the shorter
    yield "add_prior", (h[:8] + [h[0]], [1.0] * 9, [1.0], [[1.0] * 9], 0.5)            # one list twice in h
    yield "add_prior", (h, [1.0] * 9, [], [], 1.0)
    from shared.prior import SHAPE_SIGMA, Prior
    for r in range(4 if short else 40):
        kr = [fl(rng, -1, 1) for _ in range(3)]
        a = [fl(rng, -2, 2) for _ in range(3)] + [fl(rng, -12, -5) for _ in range(3)]
        f = [fl(rng, -8, 8) for _ in range(3)]
        physical = Prior(float, kr, [0.0] * 6, [SHAPE_SIGMA[0]] * 3 + [SHAPE_SIGMA[1]] * 3)
        yield "residuals", (physical, a, f)
        previous = Prior(float, kr, [fl(rng, -12, -5) for _ in range(6)], [2e-4] * 6, [fl(rng, -8, 8) for _ in range(3)],
                         fl(rng, -20, -5), fl(rng, -2, 2), fl(rng, -14, -10))
        yield "residuals", (previous, a, f)
        yield "residuals", (Prior(float, kr, [0.0] * 6, [1e-2] * 6, None, None, fl(rng, -2, 2), 2e-4), a, f)
    yield "residuals", (physical, [0.0] * 6, f)                                     # t = 0: ZeroDivisionError
    yield "residuals", (physical, [1.0, 1.0, 1.0, 0.0, 0.0, 3], f)                  # an int: Python's
    yield "residuals", (physical, [1e30, 1e30, 1e30, 0.0, 0.0, 0.0], f)             # overflows in binary32
    yield "residuals", (physical, [1.0] * 5, f)                                      # IndexError
    yield from predicted_cases(rng, short)
    for r in range(10 if short else 200):      # moments.to_float: sums of every size, either sign
        x = rng.bits(30)
        for _ in range(rng.bits(4)):
            x = (x << 30) | rng.bits(30)
        x = x >> rng.bits(5)
        yield "to_float", (-x if rng.bits(1) else x, rng.bits(9) - 256)
    for x in (0, 1, -1, (1 << 53) - 1, 1 << 53, (1 << 53) + 1, -(1 << 54) - 3, (1 << 64) - 1, 1 << 64, -(1 << 64),
              (1 << 30) - 1, 1 << 30, -(1 << 30), -(1 << 30) - 1, (1 << 62) - 1, 1 << 62, 3 << 300):
        yield "to_float", (x, -40)
    yield "to_float", (5, 2)
    yield "to_float", (1 << 200, -1200)        # underflows: the interpreter's ldexp decides, both ways
    yield "to_float", (True, 0)                # a bool: an int in Python
    yield "to_float", (2.5, 0)                 # TypeError in Python
    yield "to_float", (1 << 400, 0)            # past the powers made at import
    yield "to_float", (-(1 << 700) - 12345, -600)


def predicted_cases(rng, short):
    """(kernel name, args) for shared/predicted.py's _sphere_gradients, _variance_sum and _bias_spread."""
    from shared.predicted import _ICO
    for r in range(4 if short else 30):
        am = spd(rng, 3, 4)
        values, vectors = _python("eigh3", (am,))
        yield "_sphere_gradients", (values, vectors, am)
        low = _python("cholesky", (spd(rng, 9, 10),))
        grads = [[fl(rng) for _ in range(9)] for _ in _ICO]
        yield "_variance_sum", (low, grads, None)
        bias = [fl(rng, -30, 0) for _ in range(9)]
        yield "_bias_spread", (grads, bias, None, True)
        yield "_bias_spread", (grads, bias, None, False)
        dirs = [[fl(rng, -2, 2) for _ in range(9)] for _ in range(4)]      # a quick fit's basis: Python's
        yield "_variance_sum", (low[:4], grads, dirs)
        yield "_bias_spread", (grads, bias[:4], dirs, True)
    yield "_sphere_gradients", ([1.0, -2.0, 3.0], vectors, am)              # ValueError (sqrt of a negative)
    yield "_sphere_gradients", ([1.0, 0.0, 3.0], vectors, am)               # ZeroDivisionError
    yield "_sphere_gradients", ([1e-40, 1.0, 1.0], vectors, [[1e30] * 3] * 3)     # overflows in binary32
    low[4][4] = 0.0
    yield "_variance_sum", (low, grads, None)                               # ZeroDivisionError
    yield "_variance_sum", (low, grads[:1] + [[1.0] * 8], None)             # IndexError
    yield "_bias_spread", (grads, [1e30] * 9, None, True)                   # overflows in binary32
    yield "_bias_spread", ([], bias, None, True)                            # ZeroDivisionError


def copied(x):
    """A deep copy of nested lists (add_prior works in place: each side gets its own)."""
    return [copied(y) for y in x] if isinstance(x, list) else x


_L = None
_N = None


KERNELS = ("cholesky", "cho_solve", "solve_spd", "eigh3", "normal_matrix", "add_prior", "residuals", "_sphere_gradients",
           "_variance_sum", "_bias_spread", "sums_at", "exact", "frame_means", "shifted", "scaled", "noise_gradient", "to_float")


def _python(name, args):
    """The Python's own function (the one install() replaced), on the sums as ints (linalgc's are words)."""
    if name == "sums_at":
        from exact_cases import Sums
        args = (Sums(_N.ints(args[0].scaled)), args[1], None if args[2] is None else (_N.ints(args[2][0]), args[2][1]))
    elif name in ("exact", "noise_gradient"):
        args = (args[0], _N.ints(args[1]), args[2])
    elif name in ("frame_means", "scaled"):
        args = (_N.ints(args[0]),) + args[1:]
    if name == "to_float":
        from shared import moments
        return moments.to_float(*args)
    return _call(_N._PYTHON[KERNELS.index(name)], name, args)


def _call(f, name, args):
    if name in ("cho_solve", "residuals", "to_float", "sums_at", "exact", "frame_means", "shifted", "scaled", "noise_gradient"):
        return f(*args)
    if name == "add_prior":
        h, g = args[0], args[1]
        f(*(args + (0.0,)))
        return [g] if h is None else [h, g]
    return f(*args, num=float) if name in KERNELS[:4] else f(*args, float)


def _outcome(name, args, native):
    """The result's bytes, or the exception's class name."""
    args = tuple(copied(a) for a in args)
    from shared import iteration, predicted, prior, quadric
    where = {"add_prior": iteration, "normal_matrix": quadric, "residuals": prior.Prior, "to_float": quadric,
             "sums_at": quadric.Problem, "exact": quadric.Problem, "frame_means": quadric, "shifted": quadric,
             "scaled": quadric, "noise_gradient": quadric.Problem}.get(name, _L)
    where = predicted if name.startswith("_") else where
    try:
        r = _call(getattr(where, name), name, args) if native else _python(name, args)
    except Exception as e:  # noqa: BLE001 - compared by class
        return e.__class__.__name__
    if name in ("sums_at", "exact", "shifted", "scaled"):
        return list(r if name == "exact" else _N.ints(r)[:35])   # ints as they are (and a native's from its words)
    return bits(r)


def _cal_bits(cal):
    d = cal.diagnostics
    return bits([cal.matrix, cal.offset, cal.field, d["rms"], d["predicted_error"]]) + repr(d["iterations"]).encode()


def solves(short):
    """Whole solves, native and not: the names of those whose calibrations differ."""
    from shared.calibration import Calibration
    from shared.fit import EllipsoidFit
    from cortexm_core import sphere     # the benches' distorted sphere of 24-bit codes (an array of x, y, z)
    n = 200 if short else 1300
    pts = sphere(n)
    fit = EllipsoidFit()
    for k in range(0, 3 * n, 3):
        fit.add(pts[k], pts[k + 1], pts[k + 2])
    pts = None
    differed = []
    runs = (("full", {}), ("provisional", {"max_iter": 1}))
    names = ("full", "provisional") if short else ("full", "provisional", "quick")   # a board: no quick one (~1 s)
    got = {}
    for native in (True, False):
        if not native:
            _N.uninstall()
        try:
            for name, kw in runs:
                gc.collect()
                got[(name, native)] = cal = fit.solve(scale=0.01, **kw)
                if name == "full":
                    prior = Calibration(cal.matrix, [cal.offset[0] + 700.0, cal.offset[1] - 500.0, cal.offset[2] + 300.0],
                                        cal.field, {"predicted_error": cal.diagnostics["predicted_error"]})
            if "quick" in names:
                gc.collect()
                got[("quick", native)] = fit.solve(scale=0.01, prior=prior)
        finally:
            if _N._native is not None:
                _N.install()
    for name in names:
        if _cal_bits(got[(name, True)]) != _cal_bits(got[(name, False)]):
            differed.append(name)
    return differed


def main(root, natmod=None, short=None):
    global _L, _N
    if short is None:
        short = sys.platform not in ("linux", "darwin", "win32")    # a board: rp2, qemu
    for folder in (root, root + "/tests/micropython", root + "/desktop/bench/micropython-scripts", natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    from lcg import Rand
    try:
        import linalgc   # noqa: F401 - as the firmware imports it at boot: shared/linalg.py uses it where imported
    except (ImportError, ValueError):
        pass
    from shared import linalg, linalg_native
    _L, _N = linalg, linalg_native
    installed = linalg_native.install()
    native = linalg_native._native
    answered = [0, 0]      # all calls, the exact integer kernels' (recentre, exact)
    if native is not None:
        # count the calls the native module answered itself (None: handed to Python)
        class Counting:
            def __getattr__(self, name):
                f = getattr(native, name)

                def counted(*a):
                    r = f(*a)
                    if r is not None:
                        answered[0] += 1
                        answered[1] += name in ("recentre", "exact")
                    return r
                return counted
        linalg_native._native = Counting()
    rng = Rand(23)
    compared = differed = 0
    first = None
    for name, args in cases(rng, short):
        compared += 1
        if _outcome(name, args, True) != _outcome(name, args, False):
            differed += 1
            if first is None:
                first = name
    solved = solves(short)
    linalg_native._native = native
    declined = None
    if native is not None:
        from exact_cases import malformed_declined
        declined = malformed_declined(native, native.exact_words([7] * 35))
    from shared import moments, quadric
    # to_float is installed as the native function itself (not counted in `answered`): which one the solver calls
    to_float = "python" if quadric.to_float is moments.to_float else "native"
    print(json.dumps({"path": "native" if installed else "python", "kind": None if native is None else native.kind(), "compared": compared,
                      "differed": differed, "first": first, "answered": answered[0], "answered_exact": answered[1], "declined_malformed": declined, "solves_differed": solved,
                      "to_float": to_float}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 and sys.argv[2] else None)
