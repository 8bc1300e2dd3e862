"""The processing steps of a walked survey, by their usual names (survey-practice.md s.2).

Each step takes the traverses (desktop.survey.traverses.Traverse, changed in place)
and returns one line saying what it did; :func:`process` runs the ones switched on
in order: despike, drift, destripe (zero-median traverse). Interpolation onto a
grid is desktop.survey.gridding.
"""

import numpy as np

STEPS = ("despike", "drift", "destripe")
DESPIKE_SIGMAS = 6.0
DRIFT_DEGREE = 3            # a day's variation over an hour is smooth; line-to-line alternation is not


def robust_sigma(x):
    """1.4826 x the median absolute deviation: the rms of Gaussian noise, blind to a few outliers."""
    x = np.asarray(x, dtype=float)
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def despike(lines):
    """Replace single-sample spikes (iron flicks, dropouts) by their 3-sample median.

    A sample is a spike when it stands off the mean of its two neighbours by more than
    DESPIKE_SIGMAS robust sigmas of that difference over the whole survey (a buried
    object's anomaly spans many samples: its difference is its curvature, small).
    """
    diffs = []
    for ln in lines:
        pad = np.r_[ln.nT[1], ln.nT, ln.nT[-2]]            # mirrored ends
        diffs.append(ln.nT - 0.5 * (pad[:-2] + pad[2:]))
    sigma = max(robust_sigma(np.concatenate(diffs)), 1e-3)
    count = 0
    for ln, d in zip(lines, diffs):
        pad = np.r_[ln.nT[1], ln.nT, ln.nT[-2]]
        med = np.median(np.stack([pad[:-2], pad[1:-1], pad[2:]]), axis=0)
        spike = np.abs(d) > DESPIKE_SIGMAS * sigma
        ln.nT = np.where(spike, med, ln.nT)
        count += int(spike.sum())
    return "despike: %d samples replaced (over %.0f x %.2f nT off their neighbours' mean)" % (
        count, DESPIKE_SIGMAS, sigma)


def traverse_levels(lines):
    """(L,) each traverse's median, nT."""
    return np.array([np.median(ln.nT) for ln in lines])


def drift(lines):
    """Remove the field's slow variation: a cubic in time fitted to the traverses' medians.

    Without a base station the day's variation is read from the survey itself: the
    traverse medians against their mid times. A cubic follows a diurnal swing over
    an hour's walk but not the line-to-line alternation of heading error, which
    stays for :func:`destripe` (and is what the stripes figure measures).
    """
    levels = traverse_levels(lines)
    times = np.array([np.median(ln.t_s) for ln in lines])
    degree = min(DRIFT_DEGREE, len(lines) - 1)
    if degree < 1:
        return "drift: skipped (one traverse)"
    scale = max(times.max() - times.min(), 1e-9)
    coef = np.polyfit((times - times[0]) / scale, levels, degree)
    for ln in lines:
        ln.nT = ln.nT - np.polyval(coef, (ln.t_s - times[0]) / scale)
    span = np.polyval(coef, (times - times[0]) / scale)
    return "drift: a cubic in time through the traverse medians removed (%.1f nT over the survey)" % np.ptp(span)


def destripe(lines):
    """Zero-median traverse: subtract each line's median (heading error, drift, levelling)."""
    levels = traverse_levels(lines)
    for ln, lev in zip(lines, levels):
        ln.nT = ln.nT - lev
    return "destripe: each traverse's median subtracted (rms %.2f nT about their mean)" % float(
        np.sqrt(np.mean((levels - levels.mean()) ** 2)))


def stripes_nT(lines):
    """rms of the traverse levels (medians) about their mean, nT: the line-to-line stripes."""
    levels = traverse_levels(lines)
    return float(np.sqrt(np.mean((levels - levels.mean()) ** 2)))


def level(lines):
    """Subtract the whole survey's median: the anomaly about zero."""
    lev = float(np.median(np.concatenate([ln.nT for ln in lines])))
    for ln in lines:
        ln.nT = ln.nT - lev
    return "level: the survey's median (%.1f nT) subtracted" % lev


def process(lines, steps=STEPS, before_destripe=None):
    """Level, then run the named steps in STEPS order; before_destripe(lines) is called just
    before destripe's turn (on or off). Returns the report, a line per step."""
    unknown = set(steps) - set(STEPS)
    if unknown:
        raise ValueError("unknown processing steps: %s" % ", ".join(sorted(unknown)))
    report = [level(lines)]
    for name in STEPS:
        if name == "destripe" and before_destripe is not None:
            before_destripe(lines)
        report.append(globals()[name](lines) if name in steps else "%s: off" % name)
    return report
