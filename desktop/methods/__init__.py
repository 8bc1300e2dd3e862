"""Every calibration method on (N, 3) arrays in nT, behind one entry point.

    from desktop.methods import fit_array, magnitudes
    cal = fit_array(h, method="streaming")      # shared.calibration.Calibration, nT in/out
    mag = magnitudes(cal, h)                    # (N,) |h_c| in nT

``streaming`` is the device's own code (shared.fit) on the quantised samples;
the others are numpy references, each returning (matrix, offset, field) with
h_c = matrix @ (h - offset):

- algebraic.fit_li_griffiths : ellipsoid-specific algebraic fit (Li & Griffiths 2004)
- mle.fit_geometric          : maximum likelihood, minimises sum (|M(h-b)| - R)^2
- paper_nn.fit_paper_nn      : the paper's linear neural network (section III.B)
- objective.fit_objective    : the streaming core's own objective, evaluated on
                               the samples (no moments): the strict cross-check

narrow_float.RoundedFloat emulates a narrow float as the `num` of a solve.
"""

import numpy as np

from shared.calibration import Calibration
from shared.fit import EllipsoidFit

METHODS = ("streaming", "algebraic", "mle", "paper-nn")

# Quantisation step for float data (nT): rounding error lsb/sqrt(12) = 0.0003 nT rms.
LSB_NT = 1e-3


def quantise(h, lsb=LSB_NT):
    """(N, 3) nT floats -> list of integer triples in units of lsb."""
    return np.rint(np.asarray(h, dtype=float) / lsb).astype(np.int64).tolist()


def accumulate(h, lsb=LSB_NT):
    fit = EllipsoidFit()
    add = fit.add
    for x, y, z in quantise(h, lsb):
        add(x, y, z)
    return fit


def fit_array(h, method="streaming", field=None, float32=False, prior=None, lsb=LSB_NT, max_error=None):
    """Fit a calibration to raw readings h ((N, 3) nT); returns a Calibration on nT.

    max_error (streaming only): the predicted full-sphere error (nT) above which
    the solve refuses (degenerate_coverage); None: the core's default, 1 % of the field.

    Raises shared.fit.FitError (streaming) or ValueError (references) when the
    data cannot be calibrated.
    """
    h = np.asarray(h, dtype=float)
    if method == "streaming":
        num = np.float32 if float32 else float
        if prior is not None:
            prior = prior.scaled_input(1.0 / lsb)
        cal = accumulate(h, lsb).solve(field=field, prior=prior, num=num, scale=lsb, max_error=max_error)
        return cal.scaled_input(lsb)
    if method == "algebraic":
        from desktop.methods.algebraic import fit_li_griffiths as fun
    elif method == "mle":
        from desktop.methods.mle import fit_geometric as fun
    elif method == "paper-nn":
        from desktop.methods.paper_nn import fit_paper_nn as fun
    elif method == "objective":
        from desktop.methods.objective import fit_objective as fun
    else:
        raise ValueError("unknown method %r (choose from %s)" % (method, ", ".join(METHODS)))
    matrix, offset, out_field = fun(h, field=field)
    mag = np.linalg.norm((h - offset) @ np.asarray(matrix).T, axis=1)
    rms = float(np.sqrt(np.mean((mag - out_field) ** 2)))
    return Calibration(np.asarray(matrix).tolist(), list(map(float, offset)), out_field,
                       {"n": len(h), "rms": rms, "method": method})


def correct_array(cal, h):
    """(N, 3) calibrated vectors h_c = M (h - b), nT."""
    return (np.asarray(h, dtype=float) - np.asarray(cal.offset)) @ np.asarray(cal.matrix).T


def magnitudes(cal, h):
    """(N,) |h_c| in nT."""
    return np.linalg.norm(correct_array(cal, h), axis=1)
