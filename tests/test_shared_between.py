"""EllipsoidFit.solve(between=f): f runs between the solve's heavy steps and changes nothing.

A device drains its DRDY ring in f (device/session.py, docs/firmware.md "The finish"): a Pico's
ring holds 1.28 s and a final solve on its `.mpy` firmware takes 0.5-1.1 s, a quick
re-calibration's (gain models and the shape test) longer. The heavy step is a State (the power
sums re-centred and the exact RSS, shared/iteration.py): at most two are built between two calls
(the initial guesses), one an iteration otherwise, unless a Levenberg-Marquardt step is refused.
"""

import pytest

from desktop.bench.honesty import FIELD, drifted_day
from desktop.methods import LSB_NT, accumulate
from desktop.sim.points import directions
from shared import iteration


def _states_between(monkeypatch, solve):
    """(calibration, States built between consecutive between() calls, the last stretch included)."""
    built = [0]
    gaps = []
    init = iteration.State.__init__

    def counted(self, *args, **kwargs):
        built[0] += 1
        init(self, *args, **kwargs)

    def between():
        gaps.append(built[0])
        built[0] = 0
    monkeypatch.setattr(iteration.State, "__init__", counted)
    cal = solve(between)
    gaps.append(built[0])
    return cal, gaps


@pytest.mark.parametrize("kind", ["full", "quick"])
def test_between_splits_the_solve_and_changes_nothing(monkeypatch, kind):
    sensor, old, _, _, rng = drifted_day(3)
    cap = sensor.measure(FIELD * directions("cap", rng, 3000, 0.3 if kind == "quick" else 1.0), rng)
    sums = accumulate(cap, LSB_NT)
    prior = old.scaled_input(1.0 / LSB_NT) if kind == "quick" else None

    def solve(between=None):
        return sums.solve(field=FIELD, prior=prior, scale=LSB_NT, max_error=float("inf"), between=between)
    plain = solve()
    cal, gaps = _states_between(monkeypatch, solve)
    assert (cal.matrix, cal.offset, cal.diagnostics) == (plain.matrix, plain.offset, plain.diagnostics)
    refused = cal.diagnostics["rejected"]
    assert max(gaps) <= 2 + refused, gaps
    # every iteration is a stretch of its own (a quick one's three models and its shape test too)
    assert len(gaps) >= cal.diagnostics["iterations"], (gaps, cal.diagnostics["iterations"])
    assert sum(gaps) >= len(gaps) - 1
