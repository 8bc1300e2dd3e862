"""The live operator: the sensor's motion decided as time goes, not scripted in advance.

    op = LiveOperator(np.random.default_rng(1))
    op.set("hand", at=2.0)          # turn it by hand from t = 2 s
    op.set("hold", at=40.0)         # hold still
    q = op.orientation(t)           # (N, 4), the Motion interface AnalogChain reads
    p = op.position(t, q)

A run of segments, each one of MODES started at the attitude the previous one
ended in, so the orientation never jumps (only the angular velocity changes at
a switch, as when a hand stops). `hand` is motion.py's free tumbling by hand
(a new stretch of it, from the operator's generator, every HAND_S seconds),
`spin` a steady turn about the world vertical, `hold` one fixed attitude.
A switch takes effect at its time or at the end of what was already computed,
whichever is later: the past does not change.
"""

import numpy as np

from desktop.sim.motion import make_motion, qexp, qmul, random_quaternions

MODES = ("hand", "hold", "spin")
HAND_S = 60.0


def _conj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


class LiveOperator:
    def __init__(self, rng, rate=1.0, lever_m=0.25, mode="hold"):
        self.rng = rng
        self.rate = rate
        self.lever_m = lever_m
        q0 = random_quaternions(rng, 1)[0]
        # segments: (start s, mode, q at the start, the hand stretch or None)
        self.segments = [(0.0, mode, q0, self._hand(q0) if mode == "hand" else None)]
        self._starts = np.zeros(1)  # the segments' start times, for the search
        self.computed = 0.0         # the latest time asked for: switches never go before it

    @property
    def mode(self):
        return self.segments[-1][1]

    def set(self, mode, at):
        """From time `at` (s) on, the operator does `mode` (one of MODES)."""
        if mode not in MODES:
            raise ValueError("unknown operator mode %r (one of %s)" % (mode, ", ".join(MODES)))
        at = max(float(at), self.computed, self.segments[-1][0])
        if mode == self.mode:
            return
        q = self.orientation(np.array([at]))[0]
        self._append((at, mode, q, self._hand(q) if mode == "hand" else None))

    def _append(self, segment):
        self.segments.append(segment)
        self._starts = np.append(self._starts, segment[0])

    def _hand(self, q_start):
        """A stretch of hand motion turned so that it starts at q_start."""
        m = make_motion("hand", HAND_S, self.rng, rate=self.rate, lever_m=self.lever_m, sway_m=0.0)
        return m, qmul(q_start, _conj(m.orientation(np.array([0.0]))[0]))

    def _segment_q(self, seg, dt):
        t0, mode, q0, hand = seg
        if mode == "hold":
            return np.repeat(q0[None, :], len(dt), axis=0)
        if mode == "spin":       # about the world vertical (z down): a left rotation
            return qmul(qexp(np.outer(2 * np.pi * self.rate * dt, [0.0, 0.0, 1.0])), np.repeat(q0[None, :], len(dt), axis=0))
        motion, turn = hand
        # past the stretch's end: a new stretch from where this one stands (a hand goes on)
        return qmul(np.repeat(turn[None, :], len(dt), axis=0), motion.orientation(np.minimum(dt, HAND_S)))

    def orientation(self, t):
        """(N, 4) unit quaternions (sensor to world) at times t (N,), s."""
        t = np.asarray(t, dtype=float)
        if len(t):
            self.computed = max(self.computed, float(t.max()))
        self._extend_hands(t)
        out = np.empty((len(t), 4))
        starts = self._starts
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
        for k in np.unique(idx):
            sel = idx == k
            seg = self.segments[k]
            out[sel] = self._segment_q(seg, t[sel] - seg[0])
        return out

    def _extend_hands(self, t):
        """A hand stretch that runs out continues as a fresh one (the wrist does not stop)."""
        if not len(t):
            return
        end = t.max()
        last = self.segments[-1]
        while last[1] == "hand" and end - last[0] > HAND_S:
            q = self._segment_q(last, np.array([HAND_S]))[0]
            self._append((last[0] + HAND_S, "hand", q, self._hand(q)))
            last = self.segments[-1]

    def position(self, t, q=None):
        """(N, 3) sensor position, m: on a lever from the wrist (Motion.position without sway)."""
        q = self.orientation(t) if q is None else q
        w, x, y, z = q.T
        p = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)], axis=1)
        return p * self.lever_m
