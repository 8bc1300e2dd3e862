"""What a recording and its calibration are good for, in one line first, and what would improve them.

    counts = coverage_counts(h, edge=4)                    # shared/coverage.py's cells of (N, 3) readings
    line, warnings = verdict(predicted_nt, counts, 4, corrected, field, t)
    # "good to 0.21 nT over the sphere; to improve: nothing: ..."

The verdict names the predicted full-sphere error (what the calibration is
good to where the samples did not go), then what would bring it down: the
coverage (the largest gap named, desktop/views/sphere.py) and the rotation rate
(a residual that grows as w^2: a lagging or smearing sensor, desktop/methods/turn_rate.py, the
check `fluxcal fit`'s refusal makes too).
"""

import numpy as np

from desktop.views.coverage_text import guidance
from desktop.methods.turn_rate import rate_effect
from desktop.views.sphere import largest_gap
from shared.codes import MAX_PREDICTED_NT
from shared.coverage import Coverage

# the firmware's min_coverage (device/config.py): the share of cells a calibration wants before it
# may finish by itself; under it the fit extrapolates the shape over the rest of the sphere
MIN_COVERAGE = 0.5
# the firmware's cell_cap (device/config.py): the samples a cell gives its fit; a map shows such a cell full
CELL_CAP = 24
# the firmware's max_rms_nt: a fit whose residual exceeds it is refused (device/acceptance.py); the
# verdict's bar for a calibration that does not say what its own samples left
MAX_RMS_NT = 5.0
# a gap worth naming when coverage is otherwise enough: a tenth of the sphere, a cap of 37 degrees
# half-angle, over which the fit's shape is extrapolated rather than measured
GAP_WORTH = 0.1
MAX_COUNTED = 50000      # samples counted into the cells (pure Python: enough to find every visited cell)


def coverage_counts(h, edge=4, max_samples=MAX_COUNTED):
    """Cell counts (shared/coverage.py) of the directions of (N, 3) readings about the origin."""
    cov = Coverage(edge)
    step = max(1, len(h) // max_samples)
    for x, y, z in np.asarray(h, dtype=float)[::step].tolist():
        if x or y or z:
            cov.add(x, y, z)
    return list(cov.counts)


def coverage_warning(counts, edge, min_coverage=MIN_COVERAGE):
    """A warning line when the cells visited are fewer than min_coverage, else None."""
    share = sum(1 for c in counts if c) / float(len(counts))
    if share >= min_coverage:
        return None
    return ("WARNING: the recording covers %.0f %% of the sphere (a calibration wants %.0f %%): the fit "
            "extrapolates over the rest. Turn the sensor slowly about every axis while recording; %s"
            % (100 * share, 100 * min_coverage, guidance(counts, edge)))


def fits_elsewhere(rms, fit_rms, predicted_nt):
    """True when the recording's residual rms is more than 3x what the calibration's own samples
    left (its fit residual and its predicted error in quadrature): these samples are not like them.
    Without the fit's residual, the firmware's acceptance limit (MAX_RMS_NT) decides."""
    if fit_rms is None:
        return rms > MAX_RMS_NT
    return rms > 3.0 * np.hypot(fit_rms, predicted_nt or 0.0)


def verdict(predicted_nt, counts, edge, corrected, field, t, timed=True, min_coverage=MIN_COVERAGE, fit_rms=None):
    """(the verdict line, [warning lines]) of a calibration on a recording; fit_rms: the residual
    rms of the samples the calibration was fitted to (its diagnostics' rms), nT."""
    share = sum(1 for c in counts if c) / float(len(counts))
    improve = []
    warnings = []
    w = coverage_warning(counts, edge, min_coverage)
    gap = largest_gap(counts, edge)
    if w:
        warnings.append(w)
        improve.append("cover more of the sphere (%.0f %% now); %s" % (100 * share, guidance(counts, edge)))
    elif gap is not None and gap.fraction >= GAP_WORTH:
        improve.append("fill the %s" % guidance(counts, edge))
    slower = None
    effect = rate_effect(corrected, field, t)
    if effect is not None:
        b, se, w90 = effect.slope, effect.se, effect.w90
        # |B| low by more than three standard errors and a tenth of the predicted error at the
        # faster turns: the turning, not the noise, sets it (lag and smearing only shorten |B|)
        if b < -3 * se and -b > 0.1 * (predicted_nt or 0.0):
            slower = -b
            improve.append("turn more slowly (|B| reads %.3f nT low at %.3g %s)"
                           % (-b, w90, "deg/s" if timed else "deg per sample"))
    rms = float(np.sqrt(np.mean((np.linalg.norm(corrected, axis=1) - field) ** 2)))
    if fits_elsewhere(rms, fit_rms, predicted_nt):
        # the calibration does not fit these samples: unless the turn rate explains it (a slow
        # sensor turned fast), another sensor, iron near by or a field that moved
        head = ("NOT good here: these samples are off by %.3f nT rms (%s)%s"
                % (rms, "a fit above %g nT is refused" % MAX_RMS_NT if fit_rms is None else
                   "its own samples: %.3f nT" % fit_rms, "" if predicted_nt is None else
                   "; the calibration predicted %.3f nT over the sphere" % predicted_nt))
        if slower is None or slower < 0.5 * rms:
            improve.append("recalibrate this sensor where it is used, away from iron")
    elif predicted_nt is None:
        head = "good to %.3f nT rms on these samples (no predicted full-sphere error)" % rms
    else:
        head = "good to %.3f nT over the sphere" % predicted_nt
        if predicted_nt > MAX_PREDICTED_NT:    # e.g. a compass chip's LSB of ~100 nT
            head += " (above the %g nT `fluxcal fit` and the handheld accept)" % MAX_PREDICTED_NT
    if not improve and predicted_nt is not None and predicted_nt > MAX_PREDICTED_NT:
        improve.append("nothing in the recording (%.0f %% of the sphere covered, no error growing with the turn "
                       "rate): the samples' own scatter, %.3f nT rms, sets it" % (100 * share, rms))
    elif not improve:
        improve.append("nothing to change: %.0f %% of the sphere covered, no error growing with the turn rate"
                       % (100 * share))
    return "%s; to improve: %s" % (head, "; ".join(improve)), warnings
