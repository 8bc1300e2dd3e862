"""device/gates.py places a sample in the coverage cell shared/coverage.py's Coverage.cell names.

The gates find the cell inline (a method call is ~2 k cycles a sample on an RP2040), so the two
must agree on every direction, the cells' own boundaries included: the face edges and corners
(ties of the largest component), zero components, ratios on a cut and a unit either side of it,
the 14-bit extremes the gates' shifted sums reach, and random directions, for every `cells` the
config allows. The rate gate is opened wide and the cap raised, so every sample is placed.
"""

import math
import os
import random
import sys

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ONE = 1 << 12


def _modules():
    device = os.path.join(REPO, "device")
    if device not in sys.path:
        sys.path.insert(0, device)
    import config
    import gates
    return config, gates


def directions(n, rng):
    """Directions about the centre in the gates' 14-bit units: the boundaries, then random ones."""
    big = (1 << 14) - 1
    out = []
    for m in (1, 7, 4096, big):
        for a in (-m, 0, m):
            for b in (-m, 0, m):
                for c in (-m, 0, m):
                    if a or b or c:
                        out.append((a, b, c))
    for k in range(1, n):
        t = int(round(math.tan(math.radians(-45.0 + 90.0 * k / n)) * ONE))
        for major in (ONE, 3 * ONE, 4000):
            # p / major on the cut (t / 2^12) where it divides, and a unit either side
            p = t * major // ONE
            for d in (-1, 0, 1):
                for sign in (1, -1):
                    out += [(sign * major, p + d, p + d), (p + d, sign * major, -(p + d)), (p + d, p - d, sign * major)]
    out += [tuple(rng.randint(-big, big) for _ in range(3)) for _ in range(3000)]
    return [d for d in out if max(abs(v) for v in d) <= big and (d[0] or d[1] or d[2])]


@pytest.mark.parametrize("cells", range(2, 13))
def test_the_gates_cell_is_the_coverage_cell(cells):
    config, gates = _modules()
    from shared.coverage import Coverage
    from shared.fit import EllipsoidFit
    cfg = config.defaults()
    cfg["cells"] = cells
    cfg["cell_cap"] = 10000
    window = 2
    fit = EllipsoidFit()
    cov = Coverage(cells, cfg["cell_cap"])
    g = gates.Gates(cfg, fit, cov, window, 10.0, [0, 0, 0])
    g._st[gates._G] = (1 << 31) - 1   # no turn is too fast: every sample reaches the cells
    sh = g._st[gates._SH]
    checked = 0
    for d in directions(cells, random.Random(cells)):
        g.break_chain()       # each direction on its own: the stride's first sample is not gated
        for _ in range(g._st[gates._STRIDE]):
            g.sample(d[0] << sh, d[1] << sh, d[2] << sh)
        assert g.sample(d[0] << sh, d[1] << sh, d[2] << sh)
        i = ((g.hist_i - 1) % gates.HIST) * 5
        assert g.hist[i + 4] == cov.cell(d[0], d[1], d[2]), (cells, d)
        checked += 1
    assert checked > 3000
