"""Batch sums of a calibration session's accepted samples: the residuals' correlation in time.

    rb = ResidualBatches(fit, centre)   # fit: the session's EllipsoidFit; centre: sum units
    rb.added()                          # after each fit.add (gates.py)
    rb.removed(x, y, z)                 # after each fit.remove, last in first out
    means, counts = rb.means(cal)       # mean |h_c| - F per batch, nT, under the final fit

shared/honest.py says why: the mean residual of a batch under any calibration follows
from the batch's sums of h - c and its products (c the session's centre), so these 9
sums per batch are all the board keeps, not the session's samples. The batches' length
doubles (shared.honest.batch_length) by merging neighbours when all slots are full.

The sums are taken exactly, as differences of the fit's own integer power sums at each
batch's end (the first 10, degree <= 2: no work per sample), centred exactly, and only
then rounded to a float: 1,024 samples' sum of squares to 2**-24 of itself moves a
batch's mean residual by 6e-8 of |B|^2 / 2|B|, 0.003 nT, against the 0.03 nT a white
1 nT residual leaves in a batch mean.
"""

from array import array

from shared.honest import BATCHES, FIRST

_SLOTS = 2 * BATCHES
_W = 9               # x, y, z, xx, xy, xz, yy, yz, zz of h - c (shared.moments.ORDER 1..9)


class ResidualBatches:
    def __init__(self, fit, centre):
        self._fit = fit
        self._c = centre
        self._sums = array("f", bytes(4 * _W * _SLOTS))
        self._counts = array("i", bytes(4 * _SLOTS))   # samples summed into each slot
        self._length = FIRST
        self._cur = 0                   # the slot being filled
        self._open = 0                  # samples added since the mark, not in a slot yet
        self._mark = [0] * 10           # the fit's first 10 sums when a slot last took its samples

    def added(self):
        """A sample went into the fit: count it; close the batch when it is full."""
        self._open += 1
        if self._counts[self._cur] + self._open == self._length:
            self._close()

    def removed(self, x, y, z):
        """The latest sample (x, y, z) left the fit again (gates.py's back-off)."""
        if self._open:
            self._open -= 1                 # not in a slot yet
            return
        i = self._cur
        if not self._counts[i]:
            if not i:
                return
            i -= 1
            self._cur = i                   # the batch it closed opens again, one short
        self._counts[i] -= 1
        m = self._mark
        m[0] -= 1
        c = self._c
        v = (x, y, z)
        s = self._sums
        j = i * _W
        for a in range(3):
            m[1 + a] -= v[a]
            s[j + a] -= v[a] - c[a]
        k = 3
        for a in range(3):
            for b in range(a, 3):
                m[1 + k] -= v[a] * v[b]
                s[j + k] -= (v[a] - c[a]) * (v[b] - c[b])
                k += 1

    def _close(self):
        self._take()
        self._cur += 1
        if self._cur == _SLOTS:
            self._merge()

    def _take(self):
        """Sum the open samples into the slot being filled: the fit's sums since the mark."""
        now = self._fit.sums()
        m = self._mark
        d = [now[i] - m[i] for i in range(10)]
        self._mark = now[:10]
        n = d[0]
        c = self._c
        s = self._sums
        i = self._cur
        j = i * _W
        # exact centring: sum (x - cx) = Sx - cx n; sum (x - cx)(y - cy) = Sxy - cx Sy - cy Sx + cx cy n
        for a in range(3):
            s[j + a] += d[1 + a] - c[a] * n
        k = 3
        for a in range(3):
            for b in range(a, 3):
                s[j + k] += d[1 + k] - c[a] * d[1 + b] - c[b] * d[1 + a] + c[a] * c[b] * n
                k += 1
        self._counts[i] += n
        self._open = 0

    def _merge(self):
        """All slots full: neighbours merge, the batches double in length."""
        s = self._sums
        cnt = self._counts
        for i in range(BATCHES):
            a = 2 * i * _W
            for k in range(_W):
                s[i * _W + k] = s[a + k] + s[a + _W + k]
            cnt[i] = cnt[2 * i] + cnt[2 * i + 1]
        for i in range(BATCHES * _W, _SLOTS * _W):
            s[i] = 0.0
        for i in range(BATCHES, _SLOTS):
            cnt[i] = 0
        self._cur = BATCHES
        self._length *= 2

    def means(self, cal):
        """([mean |h_c| - F per batch, nT], [its samples]) under cal (sum units, as the fit's),
        the open batch's samples included: (|h_c|^2 - F^2) / 2F, with h - o = v + d,
        v = h - c, d = c - o: v^T G v + 2 (G d).v + d^T G d, G = M^T M."""
        if self._open:
            self._take()
        mat = cal.matrix
        g = [[sum(mat[r][a] * mat[r][b] for r in range(3)) for b in range(3)] for a in range(3)]
        d = [self._c[a] - cal.offset[a] for a in range(3)]
        gd = [sum(g[a][b] * d[b] for b in range(3)) for a in range(3)]
        const = sum(d[a] * gd[a] for a in range(3)) - cal.field * cal.field
        two_f = 2.0 * cal.field
        means = []
        counts = []
        s = self._sums
        for i in range(self._cur + 1):
            n = self._counts[i]
            if not n:
                continue
            j = i * _W
            q = 2.0 * (gd[0] * s[j] + gd[1] * s[j + 1] + gd[2] * s[j + 2])
            k = 3
            for a in range(3):
                for b in range(a, 3):
                    q += (g[a][b] if a == b else 2.0 * g[a][b]) * s[j + k]
                    k += 1
            means.append((q / n + const) / two_f)
            counts.append(n)
        return means, counts
