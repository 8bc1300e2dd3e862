"""The solver's float work through the board's kernels in C: shared/linalg.py's cholesky, cho_solve,
solve_spd and eigh3, shared/quadric.py's normal_matrix, shared/iteration.py's add_prior,
shared/prior.py's Prior.residuals, shared/predicted.py's _sphere_gradients, _variance_sum and
_bias_spread, shared/moments.py's to_float where the solver's modules call it, and the exact integer
work of a trial state and of the problem's frame, shared/quadric.py's Problem.sums_at, Problem.exact,
frame_means, shifted and scaled (on a board each of a state's ~300 big-integer operations is a heap
allocation; in C words of 512 bits, the same integers).

    from shared import linalg_native
    linalg_native.install()     # True: those now try linalgc first; False: none loaded
    linalg_native.uninstall()   # the Python's own back

linalgc.mpy (device/native/linalgc.c) does the same operations in the interpreter's own float, so
the same bits (tests/test_native_linalg.py); kind() is None where its floats are not IEEE binary32 or
binary64 (a 30-bit-float build). It is used where it is already in sys.modules, never imported here:
the firmware imports it at boot where its heap has room for it (device/app.py) and installs these at
each session's start (device/calibration_flow.py); on rp2 every load of a native module stays in the
heap. An input it does not take (None back) goes to shared/linalg.py's Python, which raises or
returns as it always did. A module of its own, so that shared/linalg.py is the same bytecode
wherever the kernels are not loaded (the .mpy firmware's quick finishes in a row were refused
no_memory more often with the hooks inside it: docs/limits.md).
"""

import sys

from shared import iteration, linalg, moments, predicted, prior, quadric, result, start

_PYTHON = (linalg.cholesky, linalg.cho_solve, linalg.solve_spd, linalg.eigh3, quadric.normal_matrix,
           iteration.add_prior, prior.Prior.residuals, predicted._sphere_gradients, predicted._variance_sum,
           predicted._bias_spread, quadric.Problem.sums_at, quadric.Problem.exact, quadric.frame_means, quadric.shifted,
           quadric.scaled, quadric.Problem.noise_gradient)
_TO_FLOAT = (quadric, start, iteration, result)     # the solver's modules that convert its exact sums
_native = None
# quadric's index tables as normal_matrix's C reads them (device/native/solver_body.h): one bytes
_TABLES = bytes([i for row in quadric._IDX4 for i in row] + [c * d for c in quadric.W_C for d in quadric.W_C]
                + [i for row in quadric._IDX3 for i in row] + list(quadric.W_C)
                + [i for row in quadric._IDX2M for i in row])
# and as exact's reads them (device/native/exact_body.h): _IDX4, _IDX3, _IDX2, _IDX1
_EXACT = bytes([i for row in quadric._IDX4 for i in row] + [i for row in quadric._IDX3 for i in row] + quadric._IDX2
               + quadric._IDX1)
_COUNT = moments.COUNT
_LOW = bytes(range(1, 10))      # the sums of degree 1 and 2, by storage index


def _cholesky(a, num):
    low = _native.cholesky(a) if num is float else None
    return _PYTHON[0](a, num) if low is None else low


def _cho_solve(low, b):
    y = _native.cho_solve(low, b)
    return _PYTHON[1](low, b) if y is None else y


def _solve_spd(a, b, num):
    y = _native.solve_spd(a, b) if num is float else None
    return _PYTHON[2](a, b, num) if y is None else y


def _eigh3(s, num, sweeps=12):
    out = _native.eigh3(s) if num is float and sweeps == 12 else None
    return _PYTHON[3](s, num, sweeps) if out is None else out


def _normal_matrix(mean, am, nf, num):
    h = _native.normal_matrix(mean, am, nf, _TABLES) if num is float else None
    return _PYTHON[4](mean, am, nf, num) if h is None else h


def _add_prior(h, g, rho, jac, lam, zero):
    if _native.add_prior(h, g, rho, jac, lam) is None:
        _PYTHON[5](h, g, rho, jac, lam, zero)


def _residuals(self, a, f):
    out = _native.prior_residuals(self, a, f) if self.num is float else None
    return _PYTHON[6](self, a, f) if out is None else out


def _sphere_gradients(a_values, a_vectors, am, num):
    out = _native.sphere_gradients(a_values, a_vectors, am, predicted._ICO) if num is float else None
    return _PYTHON[7](a_values, a_vectors, am, num) if out is None else out


def _variance_sum(low, grads, dirs, num):
    total = None if dirs or num is not float else _native.variance_sum(low, grads)
    return _PYTHON[8](low, grads, dirs, num) if total is None else total


def _bias_spread(grads, bias, dirs, centred, num):
    total = None if dirs or num is not float else _native.bias_spread(grads, bias, centred)
    return _PYTHON[9](grads, bias, dirs, centred, num) if total is None else total


def _sums_at(self, f_int, near=None):
    """Problem.sums_at in linalgc's words: COUNT Nones, then the sums' words (a bytearray) at index
    COUNT, which the next state's sums_at, exact and frame_means read (the same integers); their
    ints are made only where the Python needs them (ints())."""
    if near is None:
        sums, c = self.scaled, f_int
    else:
        sums, f_near = near
        c = [f_int[0] - f_near[0], f_int[1] - f_near[1], f_int[2] - f_near[2]]
    src = sums[_COUNT] if len(sums) > _COUNT else _native.exact_words(sums)
    out = None if src is None else _native.recentre(src, c, moments._CHAINS)
    return moments.recentred(ints(sums)[:_COUNT], c) if out is None else out     # (as the Python's sums_at)


def ints(s):
    """The sums s as ints: s, or where _sums_at left them None, made from its words."""
    return _native.exact_ints(s[_COUNT]) if s[0] is None else s


def _exact(self, s, a_int):
    out = _native.exact(s[_COUNT], a_int, _EXACT, 3 * quadric.FRAC) if len(s) > _COUNT else None
    return _PYTHON[11](self, ints(s), a_int) if out is None else out


def _shifted(sums, scale, centre):
    """moments.shifted for the Problem's sums about its centre C (scale 1): the ints (its covariance and
    the initial guesses read them), then their words (for _scaled)."""
    words = _native.exact_words(sums) if scale == 1 else None
    out = None if words is None else _native.recentre(words, centre, moments._CHAINS)
    if out is None:
        return _PYTHON[13](sums, scale, centre)
    u = _native.exact_ints(out[_COUNT])
    u.append(out[_COUNT])
    return u


def _scaled(sums, scale):
    """moments.scaled by a power of two (the Problem's frame) from the sums' words: as _sums_at's."""
    out = None
    if len(sums) > _COUNT and scale > 0 and not scale & (scale - 1):
        out = _native.scaled_words(sums[_COUNT], moments.bit_length(scale) - 1, moments.DEGREE)
    return _PYTHON[14](ints(sums), scale) if out is None else out


def _noise_gradient(self, s, a):
    """Problem.noise_gradient on a state's sums of degree 1 and 2 as ints (9 made from its words; the
    Python's own reads there, which on the .mpy firmware's heap a list of floats by index did not fit)."""
    return _PYTHON[15](self, _native.exact_ints(s[_COUNT], _LOW) if s[0] is None else s, a)


def _frame_means(s, indices, num):
    out = None
    if num is float and len(s) > _COUNT:
        out = _native.frame_floats(s[_COUNT], bytes(indices), moments.DEGREE, quadric.FRAC)
    return _PYTHON[12](ints(s), indices, num) if out is None else out


def install():
    """These through linalgc where it is loaded and matches this interpreter's floats."""
    global _native
    _native = sys.modules.get("linalgc")
    if _native is None or _native.kind() is None:
        _native = None
        return False
    linalg.cholesky, linalg.cho_solve, linalg.solve_spd, linalg.eigh3 = _cholesky, _cho_solve, _solve_spd, _eigh3
    quadric.normal_matrix, iteration.add_prior, prior.Prior.residuals = _normal_matrix, _add_prior, _residuals
    predicted._sphere_gradients, predicted._variance_sum, predicted._bias_spread = (_sphere_gradients, _variance_sum,
                                                                                   _bias_spread)
    quadric.Problem.sums_at, quadric.Problem.exact, quadric.frame_means = _sums_at, _exact, _frame_means
    quadric.shifted, quadric.scaled, quadric.Problem.noise_gradient = _shifted, _scaled, _noise_gradient
    for module in _TO_FLOAT:
        module.to_float = _native.to_float     # (an int always: a TypeError for anything else, as the Python's)
    return True


def uninstall():
    linalg.cholesky, linalg.cho_solve, linalg.solve_spd, linalg.eigh3 = _PYTHON[:4]
    quadric.normal_matrix, iteration.add_prior, prior.Prior.residuals = _PYTHON[4:7]
    predicted._sphere_gradients, predicted._variance_sum, predicted._bias_spread = _PYTHON[7:10]
    (quadric.Problem.sums_at, quadric.Problem.exact, quadric.frame_means, quadric.shifted, quadric.scaled,
     quadric.Problem.noise_gradient) = _PYTHON[10:]
    for module in _TO_FLOAT:
        module.to_float = moments.to_float
