"""Weak prior residuals for the fit: the shape of a fluxgate, or a previous calibration.

The shape of A is q = A'/t - I with A' = K^-1 A K^-1 (A in the nominal axes,
K the nominal scale per axis) and t = tr A' / 3: scale-free, zero for a sphere.
The physical prior pulls q towards 0 with widths of 0.01 (gains within
0.5 %) and 0.0175 (axes within 1 degree of orthogonal). A previous
calibration pulls q, the gain t and the offsets towards its own values.
"""

import math

from shared import linalg
from shared.quadric import PAIR

class Prior:
    """Weak prior residuals rho(a, f) and their Jacobian (9 columns)."""

    def __init__(self, num, kr, q_target, q_sigma, f_target=None, f_sigma=None, t_target=None, t_sigma=None):
        self.num = num
        self.kr = [num(k) for k in kr]
        self.q_target = [num(x) for x in q_target]
        self.q_sigma = [num(x) for x in q_sigma]
        self.f_target = [num(x) for x in f_target] if f_target else None
        self.f_sigma = num(f_sigma) if f_sigma else None
        self.t_target = num(t_target) if t_target else None
        self.t_sigma = num(t_sigma) if t_sigma else None

    def shape(self, a):
        """A' = K^-1 A K^-1 (nominal axes), t = tr A' / 3, q = A'/t - I."""
        num = self.num
        kr = self.kr
        ap = [a[m] / (kr[PAIR[m][0]] * kr[PAIR[m][1]]) for m in range(6)]
        t = (ap[0] + ap[1] + ap[2]) / num(3.0)
        q = [ap[m] / t - (num(1.0) if m < 3 else num(0.0)) for m in range(6)]
        return ap, t, q

    def residuals(self, a, f):
        num = self.num
        zero = num(0.0)
        ap, t, q = self.shape(a)
        rho = []
        jac = []
        # d t / d a_m is 1/(3 k_m^2) for the diagonal terms, 0 otherwise.
        dt = [num(1.0) / (num(3.0) * self.kr[m] * self.kr[m]) if m < 3 else zero for m in range(6)]
        for i in range(6):
            rho.append((q[i] - self.q_target[i]) / self.q_sigma[i])
            row = [zero] * 9
            for m in range(6):
                d = -ap[i] * dt[m] / (t * t)
                if m == i:
                    d = d + num(1.0) / (self.kr[PAIR[m][0]] * self.kr[PAIR[m][1]] * t)
                row[m] = d / self.q_sigma[i]
            jac.append(row)
        if self.f_target is not None:
            for i in range(3):
                rho.append((f[i] - self.f_target[i]) / self.f_sigma)
                row = [zero] * 9
                row[6 + i] = num(1.0) / self.f_sigma
                jac.append(row)
        if self.t_target is not None:
            rho.append((t / self.t_target - num(1.0)) / self.t_sigma)
            row = [zero] * 9
            for m in range(3):
                row[m] = dt[m] / (self.t_target * self.t_sigma)
            jac.append(row)
        return rho, jac



def make_prior(pb, prior, field, num, kr, k_nom, shape_sigma, offset_nt=None, gain=None):
    """The prior of a fit in pb's frame: the physical one (prior None), or one
    tying shape, gain (width `gain`, relative) and offsets (`offset_nt`) to a
    previous calibration; .a_frame and .f_target hold that calibration's
    quadric and offsets in the frame."""
    if prior is None:
        if shape_sigma is None:
            return None
        sd, so = shape_sigma
        return Prior(num, kr, [0.0] * 6, [sd, sd, sd, so, so, so])
    # A previous calibration on the same input unit: the quadric it implies
    # for today's field, A = M^T M / F^2, in this fit's frame (x 4^e).
    m = prior.matrix
    f_now = float(field) if field is not None else prior.field
    scale_frame = math.ldexp(1.0, 2 * pb.e) / (f_now * f_now)
    a_raw = []
    for i, j in PAIR:
        a_raw.append(sum(m[r][i] * m[r][j] for r in range(3)) * scale_frame)
    ap = [a_raw[k] / (kr[PAIR[k][0]] * kr[PAIR[k][1]]) for k in range(6)]
    t = (ap[0] + ap[1] + ap[2]) / 3.0
    q = [ap[k] / t - (1.0 if k < 3 else 0.0) for k in range(6)]
    det_gain = abs(linalg.det3(m)) ** (1.0 / 3.0)  # output unit per input unit
    f_target = [(prior.offset[i] - pb.centre[i]) / math.ldexp(1.0, pb.e) for i in range(3)]
    f_sigma = (offset_nt or PRIOR_OFFSET_NT) / det_gain / math.ldexp(1.0, pb.e)
    pr = Prior(num, kr, q, [PRIOR_SHAPE] * 6, f_target, f_sigma, t, gain or PRIOR_SHAPE)
    pr.a_frame = a_raw
    return pr


# The physical prior's widths on the shape (diagonal, off-diagonal): gains within
# 0.5 %, axes within 1 degree of orthogonal. The default of every solve's shape_sigma.
SHAPE_SIGMA = (0.01, 0.0175)

# A previous calibration of the same sensor: how far today's may differ.
# Shape and gain within 2e-4 (about 10 nT at 50,000 nT); offsets within 10 nT
# (fluxgate offset drift with temperature is of that order over a field day).
PRIOR_SHAPE = 2e-4
PRIOR_OFFSET_NT = 10.0


