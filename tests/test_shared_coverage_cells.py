"""The coverage cell of a direction on the cells' own boundaries (shared/coverage.py), on every interpreter.

The rule, stated apart from the code (the module docstring and test_shared_coverage's layout):
- the face is the axis of the largest |component|, ties going to x, then y, then z; its
  sign is the component's, a zero (either sign: -0.0 == 0) counting as positive;
- on it, (p, q) are the other two components in order (x: y, z; y: x, z; z: x, y) and each
  bin is the number of cuts at or below p / major: the cuts are tan(-45 + 90 k / n degrees),
  k = 1..n-1, as integer ratios of 2^12, so a direction exactly on a cut is in the upper cell;
- the cell is (face * n + bin of p) * n + bin of q; the zero direction has none (ValueError).
The reference below applies it in exact rational arithmetic. The directions are the ones a
boundary decides: an exact zero component (0, 0.0, -0.0), the axes, the 45 degree face edges
and corners, and ratios exactly on a cut and one unit below it, as integers (the firmware's
codes, up to 2^23) and as floats (exact in every interpreter's float: at most 22 bits).
"""

import json
import math
import subprocess
import sys
from fractions import Fraction

import pytest

from tests.interpreters import INTERPRETERS, need

SCRIPT = __file__.rsplit("/", 1)[0] + "/micropython/coverage_cells.py"
EDGES = (1, 2, 3, 4, 5, 12)        # the config's range of `cells` (2..12), the default 4, and 1
ONE = 1 << 12


def cuts(n):
    return [Fraction(int(round(math.tan(math.radians(-45.0 + 90.0 * k / n)) * ONE)), ONE) for k in range(1, n)]


def reference_cell(n, d):
    v = [Fraction(x) for x in d]          # Fraction(-0.0) == 0: a signed zero is zero
    mags = [abs(x) for x in v]
    if max(mags) == 0:
        return "ValueError"
    axis = mags.index(max(mags))          # the first of equal largest: x, then y, then z
    face = 2 * axis + (0 if v[axis] >= 0 else 1)
    p, q = [v[i] for i in range(3) if i != axis]
    i = sum(1 for c in cuts(n) if p / mags[axis] >= c)
    j = sum(1 for c in cuts(n) if q / mags[axis] >= c)
    return (face * n + i) * n + j


def boundary_directions():
    """Components as the script reads them: ints, or floats as strings ("N/D" or "-0.0")."""
    dirs = []
    zeros = (0, "0/1", "-0.0")
    for axis in range(3):
        for sign in (1, -1, "1/1", "-1/1", 4096, -(1 << 23)):
            for z1 in zeros:
                for z2 in zeros:
                    d = [z1, z2]
                    d.insert(axis, sign)
                    dirs.append(d)
    # one minor component exactly zero, the other anywhere (the bins of p and of q apart)
    for a, b in ((5, 3), (5, -3), (7, 7), (7, -7), ("5/2", "-0.0"), ("-5/2", "0/1")):
        for z in zeros:
            dirs += [[a, z, b], [a, b, z], [z, a, b], [b, a, z], [z, b, a], [b, z, a]]
    # face edges and corners: |p| = major, ties between faces
    for s in ((1, 1, 0), (1, -1, 0), (-1, 1, 0), (0, 1, -1), (-1, 0, -1), (1, 1, 1), (-1, -1, -1),
              (1, -1, 1), (-3, 3, -3), ("1/2", "-1/2", "-0.0"), ("-0.0", "1/2", "1/2")):
        dirs.append(list(s))
    # exactly on each cut, and one unit below it, for every edge (major 2^12 and 2^23)
    for n in EDGES:
        for c in cuts(n):
            for major, unit in ((ONE, 1), (1 << 23, 1)):
                on = int(c * major)
                for p in (on, on - unit):
                    dirs += [[major, p, 0], [-major, 0, p], [p, -major, 1], [p, 1, major]]
            dirs.append(["1/1", "%d/%d" % (c.numerator, c.denominator), "-0.0"])
    dirs.append([0, "-0.0", "0/1"])       # the zero direction: refused
    return dirs


def run(interpreter, root, tmp_path):
    path = tmp_path / "cells.json"
    path.write_text(json.dumps({"edges": EDGES, "dirs": boundary_directions()}))
    proc = subprocess.run([interpreter, SCRIPT, str(path), root], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def as_number(x):
    if not isinstance(x, str):
        return x
    return -0.0 if x == "-0.0" else Fraction(x)


def check(got):
    dirs = boundary_directions()
    for n, cells in zip(EDGES, got):
        want = [reference_cell(n, [as_number(x) for x in d]) for d in dirs]
        wrong = [(d, g, w) for d, g, w in zip(dirs, cells, want) if g != w]
        assert not wrong, "edge %d: (direction, cell, rule's cell) %r" % (n, wrong[:5])


def test_the_directions_reach_every_boundary():
    # the set is not vacuous: exact zeros land in the upper bin of the middle cut, ties go to x
    assert reference_cell(4, [1, 0, -0.0]) == reference_cell(4, [1, 0.0, 0.0]) == (0 * 4 + 2) * 4 + 2
    assert reference_cell(4, [-0.0, -1, 0]) == (3 * 4 + 2) * 4 + 2
    assert reference_cell(4, [1, 1, 1]) == (0 * 4 + 3) * 4 + 3
    assert reference_cell(4, [0, 0, 0]) == "ValueError"


def test_cpython_follows_the_rule(root, tmp_path):
    check(run(sys.executable, root, tmp_path))


@pytest.mark.parametrize("name", INTERPRETERS)
def test_interpreter_follows_the_rule(name, root, tmp_path):
    check(run(need(name), root, tmp_path))
