"""Maximum-likelihood geometric fit: minimise sum (|M (h - b)| - R)^2.

With isotropic noise on |h_c| this is the ML estimate; M symmetric (6), b (3),
R absorbed into M. Started from the Li-Griffiths fit, solved by
Levenberg-Marquardt with the analytic Jacobian. No prior: under partial
coverage it extrapolates freely (the issue's unconstrained MLE).
"""

import numpy as np

from desktop.methods._common import levenberg_marquardt, normalise, quadric_to_calibration, sym6
from desktop.methods.algebraic import fit_li_griffiths


def fit_geometric(h, field=None, start=None):
    v, centre, scale = normalise(h)
    if start is None:
        try:
            m0, b0, f0 = fit_li_griffiths(h)
            m0 = m0 * scale / f0
            b0 = (b0 - centre) / scale
        except (ValueError, np.linalg.LinAlgError):
            m0, b0 = np.eye(3), np.zeros(3)
    else:
        m0, b0 = start
    p0 = np.concatenate([[m0[0, 0], m0[1, 1], m0[2, 2], m0[0, 1], m0[0, 2], m0[1, 2]], b0])

    def fun(p):
        m = sym6(p)
        d = v - p[6:]
        hc = d @ m  # m symmetric
        norm = np.linalg.norm(hc, axis=1)
        r = norm - 1.0
        u = hc / norm[:, None]
        jac = np.empty((len(v), 9))
        # d|M d|/dM_ij for symmetric M: u_i d_j + u_j d_i (i != j), u_i d_i (i == j)
        jac[:, 0] = u[:, 0] * d[:, 0]
        jac[:, 1] = u[:, 1] * d[:, 1]
        jac[:, 2] = u[:, 2] * d[:, 2]
        jac[:, 3] = u[:, 0] * d[:, 1] + u[:, 1] * d[:, 0]
        jac[:, 4] = u[:, 0] * d[:, 2] + u[:, 2] * d[:, 0]
        jac[:, 5] = u[:, 1] * d[:, 2] + u[:, 2] * d[:, 1]
        jac[:, 6:] = -u @ m
        return r, jac

    p = levenberg_marquardt(fun, p0)
    m = sym6(p)
    a = (m @ m) / scale**2
    return quadric_to_calibration(a, centre + p[6:] * scale, field)
