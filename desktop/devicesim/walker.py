"""A surveyor on the live handheld: waits at the first line's start, then walks the site's grid
and presses the button at each line's start and end, so the firmware records a survey byte by byte.

    walker = Walker(scenario.walk())       # a Scenario with motion="survey" (desktop/sim/walk.py)
    handheld = Handheld(scenario, operator=walker)
    presses = walker.begin(world_time - handheld.t0)   # the `walk` action: the presses' walk times

Before `walk` the sensor is held as for walking at the first line's start (the walk's first
attitude, on the spot); from `walk` on it follows the walk (desktop/sim/walk.py: the pace,
the turns, the wobble) over the site's field (desktop/sim/site.py), and at the end it stands
at the last line's end. The marks are the walk's own (`line_marks`, a human's +-30 ms): the
thumb closes the contact then and holds it PRESS_S, a short press (device/button.py).
"""

import numpy as np

PRESS_S = 0.2       # a short press: well over the 30 ms debounce, well under the 1.5 s long press


class Walker:
    def __init__(self, walk):
        self.walk = walk
        self.start = None           # walk time 0 in the handheld's motion time, once walking
        self.computed = 0.0         # the latest time asked for: the walk never starts before it

    @property
    def mode(self):
        return "waiting to walk" if self.start is None else "walking the grid"

    def set(self, mode, at):
        raise ValueError("the surveyor walks the grid (action walk); %s is for the calibration's operator" % mode)

    def begin(self, at):
        """Walk from motion time `at` (s; not before what the chips already hold); the times of the
        presses, each (down, up) in motion time."""
        if self.start is None:
            self.start = max(float(at), self.computed)
        marks = np.asarray(self.walk.line_marks, dtype=float).ravel() + self.start
        return [(float(t), float(t) + PRESS_S) for t in marks]

    def _walk_time(self, t):
        t = np.asarray(t, dtype=float)
        if len(t):
            self.computed = max(self.computed, float(t.max()))
        if self.start is None:
            return np.zeros(len(t))
        return np.clip(t - self.start, 0.0, self.walk.seconds)

    def orientation(self, t):
        return self.walk.orientation(self._walk_time(t))

    def position(self, t, q=None):
        return self.walk.position(self._walk_time(t))
