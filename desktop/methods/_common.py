"""Helpers shared by the numpy references: normalisation, symmetric square root, LM."""

import numpy as np


def normalise(h):
    """Centre on the mean and scale by the rms spread; returns (v, centre, scale)."""
    h = np.asarray(h, dtype=float)
    centre = h.mean(axis=0)
    scale = np.sqrt(np.mean(np.sum((h - centre) ** 2, axis=1)))
    if not scale > 0:
        raise ValueError("samples span no volume")
    return (h - centre) / scale, centre, scale


def sqrtm_spd(a):
    """Symmetric square root of a symmetric positive definite matrix."""
    w, v = np.linalg.eigh(a)
    if w.min() <= 0:
        raise ValueError("quadric is not an ellipsoid")
    return (v * np.sqrt(w)) @ v.T


def sym6(p):
    """3x3 symmetric matrix from (A11, A22, A33, A12, A13, A23)."""
    return np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])


def quadric_to_calibration(a, centre, field=None):
    """(matrix, offset, field) from v^T A v = 1 about `centre`.

    The gain convention matches shared/: a known field sets |h_c| = field; an
    unknown one fixes det(M) = 1 so the field is the fitted radius.
    """
    g = sqrtm_spd(a)
    if field is None:
        det = np.linalg.det(g)
        return g / np.cbrt(det), np.asarray(centre, float), float(1.0 / np.cbrt(det))
    return g * field, np.asarray(centre, float), float(field)


def levenberg_marquardt(fun, p0, max_iter=200, tol=1e-14):
    """Minimise |r(p)|^2 for fun(p) -> (r, J); returns p."""
    p = np.asarray(p0, dtype=float).copy()
    r, jac = fun(p)
    cost = r @ r
    mu = 1e-3
    for _ in range(max_iter):
        jtj = jac.T @ jac
        g = jac.T @ r
        improved = False
        for _ in range(20):
            step = np.linalg.solve(jtj + mu * np.diag(np.diag(jtj)), -g)
            r_new, jac_new = fun(p + step)
            cost_new = r_new @ r_new
            if np.isfinite(cost_new) and cost_new <= cost:
                p = p + step
                r, jac, cost = r_new, jac_new, cost_new
                mu = max(mu / 10.0, 1e-12)
                improved = True
                break
            mu *= 10.0
        if not improved or np.max(np.abs(step)) < tol:
            break
    return p
