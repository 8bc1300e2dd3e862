"""Repeated measurements for the benchmarks: run N times, report the median and (min, max).

The project's rule for figures in the README and docs: on this noisy shared machine a timing is
the median over repeated runs with the range beside it, never a best run. Figures that should not
vary (codes, heap bytes, iteration counts) are checked with `same` and flagged if they do.
"""

from typing import NamedTuple

import numpy as np


class Spread(NamedTuple):
    median: float
    lo: float
    hi: float
    n: int


def spread(values):
    """Median, min and max of the repeated values (NaNs ignored, as failed runs)."""
    a = np.asarray(values, dtype=float)
    a = a[~np.isnan(a)]
    if a.size == 0:
        return Spread(float("nan"), float("nan"), float("nan"), 0)
    return Spread(float(np.median(a)), float(a.min()), float(a.max()), int(a.size))


def fmt(values, f="%.2f", unit=""):
    """'4.86 (4.10-5.20)': the median, then the range over the runs. One run: just the value."""
    s = values if isinstance(values, Spread) else spread(values)
    if s.n == 0:
        return "n/a"
    if s.n == 1:
        return (f % s.median) + unit
    sep = " to " if s.lo < 0 else "-"
    return "%s%s (%s%s%s)" % (f % s.median, unit, f % s.lo, sep, f % s.hi)


def same(values):
    """True if every repeat gave the same value (for figures that must be deterministic)."""
    values = list(values)
    return all(v == values[0] for v in values[1:])


def det(values, f="%d", what=None, notes=None):
    """A figure that should be deterministic: the value if all runs agree, otherwise the median and
    range marked 'varies', with a line added to `notes` (if given) naming `what`."""
    values = list(values)
    if same(values):
        return f % values[0]
    if notes is not None:
        notes.append("%s varies over the %d runs: %s" % (what or "a figure", len(values),
                                                          ", ".join(f % v for v in values)))
    return fmt(values, f) + " varies"
