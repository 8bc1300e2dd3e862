"""Coverage cells: roughly equal area, integer and float agree, the per-cell cap."""

import numpy as np

from shared.coverage import Coverage
from desktop.sim.points import cap_directions, uniform_directions


def test_cells_are_roughly_equal_area():
    rng = np.random.default_rng(0)
    cov = Coverage(4)
    idx = [cov.cell(*p) for p in uniform_directions(rng, 200000).tolist()]
    counts = np.bincount(idx, minlength=cov.n_cells)
    # Equal-angle cube cells: area ratio 1.27 at n = 4; the count per cell
    # (~2083) scatters by ~2 %, so 1.35 is a safe bound.
    assert cov.n_cells == 96
    assert counts.min() > 0 and counts.max() / counts.min() < 1.35


def test_integer_and_float_directions_agree():
    rng = np.random.default_rng(1)
    cov = Coverage(4)
    v = uniform_directions(rng, 5000)
    ints = np.rint(v * 2**22).astype(np.int64).tolist()
    assert [cov.cell(*p) for p in ints] == [cov.cell(*p) for p in (np.array(ints) / 2**22).tolist()]


def test_fraction_tracks_a_cap():
    rng = np.random.default_rng(2)
    for fraction in (0.1, 0.26, 0.6, 1.0):
        cov = Coverage(4)
        for p in cap_directions(rng, 50000, fraction).tolist():
            cov.add(*p)
        # Cells cut by the cap's rim count as covered: allow one ring of cells.
        assert fraction - 0.02 <= cov.fraction() <= fraction + 0.2


def test_cap_limits_each_cell():
    cov = Coverage(2, cap=3)
    assert [cov.add(1, 0, 0) for _ in range(5)] == [True, True, True, False, False]
    assert cov.counts[cov.cell(1, 0, 0)] == 3
    cov.remove(1, 0, 0)
    assert cov.add(1, 0, 0) and not cov.add(1, 0, 0)
    cov.reset()
    assert cov.fraction() == 0.0
