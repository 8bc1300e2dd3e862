"""Ellipsoid-specific algebraic fit (Li & Griffiths 2004, IEEE GMP).

The general quadric a x^2 + b y^2 + c z^2 + 2f yz + 2g xz + 2h xy + 2p x + 2q y
+ 2r z + d = 0 is fitted in least squares subject to k J - I^2 = 1 with k = 4
(I = a + b + c, J = ab + bc + ac - f^2 - g^2 - h^2), which guarantees an
ellipsoid when the data are not too far from a sphere. It is solved as a
generalised eigenproblem on the 6x6 reduced scatter matrix.
"""

import numpy as np

from desktop.methods._common import normalise, quadric_to_calibration


def fit_li_griffiths(h, field=None):
    v, centre, scale = normalise(h)
    x, y, z = v.T
    d = np.column_stack([x * x, y * y, z * z, 2 * y * z, 2 * x * z, 2 * x * y, 2 * x, 2 * y, 2 * z, np.ones_like(x)])
    s = d.T @ d
    s11, s12, s22 = s[:6, :6], s[:6, 6:], s[6:, 6:]
    k = 4.0
    c1 = np.zeros((6, 6))
    c1[:3, :3] = k / 2.0 - 1.0
    np.fill_diagonal(c1[:3, :3], -1.0)
    c1[3:, 3:] = -k * np.eye(3)
    reduced = np.linalg.solve(c1, s11 - s12 @ np.linalg.solve(s22, s12.T))
    w, vec = np.linalg.eig(reduced)
    w = np.real(w)
    vec = np.real(vec)
    v1 = vec[:, np.argmax(w)]
    v2 = -np.linalg.solve(s22, s12.T @ v1)
    a_, b_, c_, f_, g_, h_ = v1
    p = v2[:3]
    dd = v2[3]
    a = np.array([[a_, h_, g_], [h_, b_, f_], [g_, f_, c_]])
    if np.trace(a) < 0:
        a, p, dd = -a, -p, -dd
    c = -np.linalg.solve(a, p)
    kappa = c @ a @ c - dd
    if not kappa > 0:
        raise ValueError("algebraic fit gave no ellipsoid")
    a_n = a / kappa / scale**2
    return quadric_to_calibration(a_n, centre + c * scale, field)
