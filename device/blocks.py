"""The survey's blocks: the sums of a block's samples (device/survey.py's Output averages them).

    sv = Survey(cfg, window, decim_rate_hz)
    blk = sv.sample(sx, sy, sz, st, f)     # None, or a block's sums: (x, y, z, t codes; |h_c|) and n
    sv.words                               # fitsums.survey's, where it loads: the C sums there

A block over 1/survey_hz (0.1 s at the default 10 Hz, the paper's moving average width, IV.C)
sums |h_c| of every decimated sample -- rotation invariant -- and, separately, the raw vector, in
integers: in C in `words` (fitsums.survey, device/native/hc.h) where it loads, in Python here (the
reference, and the C's fall-back for a sample past its words). Averaging the vectors and taking
|.| afterwards would shrink |B| by ~B (w T)^2/24 while the operator turns: 769 nT at 1 rev/s over
0.1 s (docs/simulator.md, smearing).
"""

from array import array
from struct import unpack_from

try:
    from fitsums import survey as _native_survey
except (ImportError, ValueError):
    _native_survey = None
# fitsums.survey's words (an array("H"), hc.h): five 64-bit sums (x, y, z, t, |h_c|) of four
# limbs each, the samples the block still takes, 1 if |h_c| is summed (else 0), its numbers
_LEFT, _HAS_F, _NUMBERS_AT = 20, 21, 22


class Survey:
    """The output blocks' sums: in C (fitsums.survey, Output.sample calls it) in `words` where it
    loads (native=True), counting down words[_LEFT]; sample() is the pure-Python way (the reference,
    and the C's fall-back for a sample past its words: its sums here); finish() adds the two."""

    def __init__(self, cfg, window, sample_hz, native=True):
        self.window = window
        self.per_block = max(1, int(sample_hz / cfg["survey_hz"] + 0.5))
        self.blocks = 0
        # blocks under 2**16 samples: the C's 64-bit sums cannot overflow, LEFT is a limb (hc.h)
        self.words = array("H", [0] * (_NUMBERS_AT + 64)) if native and _native_survey and self.per_block < 1 << 16 else None
        self._zeros = array("H", bytes(2 * _LEFT))     # restart's: one slice store, not 20 (~10 k cycles)
        self.restart()

    def restart(self):
        """Drop the open block (its samples were taken without |h_c|)."""
        self._n = 0
        self.mixed = False       # a sample of the block summed here, past the C's words
        self._sx = self._sy = self._sz = self._st = self._f = 0
        w = self.words
        if w is not None:
            w[:_LEFT] = self._zeros
            w[_LEFT] = self.per_block

    def sample(self, sx, sy, sz, st, f):
        """Accumulate; at the end of a block return its sums (x, y, z, t codes; f) and n."""
        self._sx += sx
        self._sy += sy
        self._sz += sz
        self._st += st
        self._f += f
        w = self.words
        if w is None:
            self._n += 1
            return self.finish() if self._n >= self.per_block else None
        self.mixed = True
        w[_LEFT] -= 1
        return None if w[_LEFT] else self.finish()

    def finish(self):
        """The full block's sums (x, y, z, t codes; f) and n, the next block opened."""
        w = self.words
        # the C's five 64-bit two's complements, low limb first (little-endian, as the boards and
        # hc.h have them): one unpacking in C, small ints where they fit (x, y, z, t), instead of
        # the limbs read and joined in bytecode (~36 k cycles a block on an RP2040, ~18 k so)
        s = (0, 0, 0, 0, 0) if w is None else unpack_from("<5q", w)
        s = (s[0] + self._sx, s[1] + self._sy, s[2] + self._sz, s[3] + self._st, s[4] + self._f, self.per_block)
        self.blocks += 1
        self.restart()
        return s
