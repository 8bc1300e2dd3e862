"""The streaming core's objective evaluated directly on the samples (numpy, float64).

Independent of shared/'s moment algebra and fixed-point state: residuals
r_i = v_i^T A v_i - 1 (v = h - b) per sample, the same weak shape prior
rho = (q(A) - q0) / sigma with q = A / (tr A / 3) - I, and the same
stationarity condition  sum r dr/dp + (RSS/N) sum rho drho/dp = 0,
reached by Gauss-Newton on the stacked residuals [r; sqrt(RSS/N) rho] with the
weight refreshed every iteration. Agreement with shared.fit to 1e-6 nT is the
test that the moment algebra is right.
"""

import numpy as np

from desktop.methods._common import normalise, quadric_to_calibration, sym6
from desktop.methods.algebraic import fit_li_griffiths
from shared.prior import SHAPE_SIGMA

_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def _shape(a6):
    t = (a6[0] + a6[1] + a6[2]) / 3.0
    q = a6 / t - np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    dt = np.array([1 / 3.0, 1 / 3.0, 1 / 3.0, 0.0, 0.0, 0.0])
    dq = np.eye(6) / t - np.outer(a6, dt) / t**2
    return q, dq


def fit_objective(h, field=None, shape_sigma=SHAPE_SIGMA, max_iter=100):
    v, centre, scale = normalise(h)
    m0, b0, f0 = fit_li_griffiths(h)
    a0 = (m0 @ m0) / f0**2 * scale**2
    p = np.concatenate([[a0[i, j] for i, j in _PAIRS], (b0 - centre) / scale])
    sigma = None
    if shape_sigma is not None:
        sd, so = shape_sigma
        sigma = np.array([sd, sd, sd, so, so, so])
    n = len(v)
    for _ in range(max_iter):
        a = sym6(p)
        d = v - p[6:]
        w = np.column_stack([d[:, 0] ** 2, d[:, 1] ** 2, d[:, 2] ** 2, 2 * d[:, 0] * d[:, 1], 2 * d[:, 0] * d[:, 2], 2 * d[:, 1] * d[:, 2]])
        r = w @ p[:6] - 1.0
        jac = np.hstack([w, -2.0 * d @ a])
        jtj = jac.T @ jac
        g = jac.T @ r
        if sigma is not None:
            lam = (r @ r) / n
            q, dq = _shape(p[:6])
            rho = q / sigma
            jp = np.zeros((6, 9))
            jp[:, :6] = dq / sigma[:, None]
            jtj = jtj + lam * jp.T @ jp
            g = g + lam * jp.T @ rho
        step = np.linalg.solve(jtj, -g)
        p = p + step
        if np.max(np.abs(step)) < 1e-15:
            break
    return quadric_to_calibration(sym6(p) / scale**2, centre + p[6:] * scale, field)
