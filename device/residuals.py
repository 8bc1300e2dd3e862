"""Batch sums of a calibration session's accepted samples: the residuals' correlation in time.

    rb = ResidualBatches(fit, centre)   # fit: the session's EllipsoidFit; centre: sum units
    rb.added()                          # after each fit.add (gates.py; gatesc.c counts in
                                        # rb._due itself, calling it for a batch's last sample)
    rb.removed(x, y, z)                 # after each fit.remove, last in first out
    rb.flush()                          # then rb.sums / counts / cur / width / centre: the batches
                                        # (residual_stats.py reads them at the finish)

shared/honest.py says why: the mean residual of a batch under any calibration follows
from the batch's sums of h - c and its products (c the session's centre), so these 9
sums per batch are all the board keeps, not the session's samples. The batches' length
doubles (shared.honest.batch_length) by merging neighbours when all slots are full.

The sums are taken exactly, as differences of the fit's own integer power sums at each
batch's end (the first 10, degree <= 2: no work per sample; on a board each big-integer
operation there is an allocation, so the fewest: docs/benchmarks.md), centred exactly, and only
then rounded to a float: 1,024 samples' sum of squares to 2**-24 of itself moves a
batch's mean residual by 6e-8 of |B|^2 / 2|B|, 0.003 nT, against the 0.03 nT a white
1 nT residual leaves in a batch mean.
"""

from array import array

from shared.honest import BATCHES, FIRST

SLOTS = 2 * BATCHES
WIDTH = 9               # x, y, z, xx, xy, xz, yy, yz, zz of h - c (shared.moments.ORDER 1..9)


def _monomials(x, y, z):
    """The 9 degree-1 and -2 monomials of (x, y, z) in ORDER 1..9."""
    return (x, y, z, x * x, x * y, x * z, y * y, y * z, z * z)


class ResidualBatches:
    def __init__(self, fit, centre):
        self._fits = [fit]
        self.centre = centre
        self.width = WIDTH
        self.sums = array("f", bytes(4 * WIDTH * SLOTS))
        self.counts = array("i", bytes(4 * SLOTS))   # samples summed into each slot
        self._length = FIRST
        self.cur = 0                    # the slot being filled
        # [samples added since the mark, not in a slot yet; samples left until the slot is full]:
        # gatesc.c counts a taken sample here itself and calls added() only for the last one
        self._due = array("i", [0, FIRST])
        self._marks = [[0] * 10]        # the fits' first 10 sums when a slot last took its samples

    def attach(self, below, above):
        """Follow the tau estimate's nodes too (lagfit.py; before the first sample): the fits of
        the samples x + t e at t = -1 and 1 tau steps (shared.tausums), so that each batch holds
        its sums as A + B t + C t^2 (degree <= 2 in t: three nodes tell it) and the means can be
        read at the estimated tau. 27 floats a batch instead of 9."""
        self._fits = [self._fits[0], below, above]
        self.width = 3 * WIDTH
        self.sums = array("f", bytes(4 * self.width * SLOTS))
        self._marks = [[0] * 10, [0] * 10, [0] * 10]

    def added(self):
        """A sample went into the fit: count it; close the batch when it is full."""
        d = self._due
        d[0] += 1
        d[1] -= 1
        if not d[1]:
            self._close()

    def removed(self, x, y, z, ex=0, ey=0, ez=0):
        """The latest sample (x, y, z; its tau step ex, ey, ez) left the fit again (gates.py's back-off)."""
        d = self._due
        if d[0]:
            d[0] -= 1                       # not in a slot yet
            d[1] += 1
            return
        i = self.cur
        if not self.counts[i]:
            if not i:
                return
            i -= 1
            self.cur = i                   # the batch it closed opens again, one short
        self.counts[i] -= 1
        d[1] = self._length - self.counts[i]
        c = self.centre
        samples = ((x, y, z), (x - ex, y - ey, z - ez), (x + ex, y + ey, z + ez))[:len(self._fits)]
        centred = []
        for m, v in zip(self._marks, samples):
            m[0] -= 1
            raw = _monomials(v[0], v[1], v[2])
            for k in range(WIDTH):
                m[1 + k] -= raw[k]
            centred.append(_monomials(v[0] - c[0], v[1] - c[1], v[2] - c[2]))
        self._store(i, centred, -1)

    def flush(self):
        """The open batch's samples into its slot (before its sums are read: residual_stats.py)."""
        if self._due[0]:
            self._take()

    def _close(self):
        self._take()
        self.cur += 1
        if self.cur == SLOTS:
            self._merge()
        self._due[1] = self._length - self.counts[self.cur]

    def _take(self):
        """Sum the open samples into the slot being filled: each fit's sums since its mark,
        centred exactly (sum (x - cx) = Sx - cx n; sum (x - cx)(y - cy) = Sxy - cx Sy - cy Sx
        + cx cy n) before any rounding; about a zero centre (no prior) they are the sums."""
        c = self.centre
        centred = []
        n = 0
        for f, fit in enumerate(self._fits):
            now = fit.low_sums()
            m = self._marks[f]
            d = [now[i] - m[i] for i in range(10)]
            self._marks[f] = now
            n = d[0]
            if not (c[0] or c[1] or c[2]):     # nothing to centre them by (no prior)
                out = d[1:]
            else:
                # sum (x - cx)(y - cy) = Sxy - cx Sy - cy (Sx - cx n): four big-integer
                # operations, each an allocation on a board, where the expanded form takes six
                out = [d[1 + a] - c[a] * n for a in range(3)]
                for a in range(3):
                    for b in range(a, 3):
                        out.append(d[1 + len(out)] - c[a] * d[1 + b] - c[b] * out[a])
            centred.append(out)
        self._store(self.cur, centred, 1)
        self.counts[self.cur] += n
        self._due[0] = 0

    def _store(self, i, centred, sign):
        """Add sign x the centred sums (one list per fit) into slot i: A, and with the nodes
        B = (S(1) - S(-1)) / 2 and C = (S(1) + S(-1)) / 2 - A."""
        s = self.sums
        j = i * self.width
        a = centred[0]
        for k in range(WIDTH):
            # (no sign * a[k] when adding: on a board each operation on a big int is an allocation)
            s[j + k] += a[k] if sign > 0 else -a[k]
        if len(centred) == 3:
            lo, hi = centred[1], centred[2]
            for k in range(WIDTH):
                s[j + WIDTH + k] += sign * (hi[k] - lo[k]) / 2
                s[j + 2 * WIDTH + k] += sign * ((hi[k] + lo[k]) / 2 - a[k])

    def _merge(self):
        """All slots full: neighbours merge, the batches double in length."""
        s = self.sums
        w = self.width
        cnt = self.counts
        for i in range(BATCHES):
            a = 2 * i * w
            for k in range(w):
                s[i * w + k] = s[a + k] + s[a + w + k]
            cnt[i] = cnt[2 * i] + cnt[2 * i + 1]
        for i in range(BATCHES * w, SLOTS * w):
            s[i] = 0.0
        for i in range(BATCHES, SLOTS):
            cnt[i] = 0
        self.cur = BATCHES
        self._length *= 2
