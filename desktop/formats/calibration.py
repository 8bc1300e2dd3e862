"""Calibration records as JSON files: shared.calibration.Calibration.to_dict, indented."""

import json

from desktop.formats import FormatError
from shared.calibration import Calibration, plausibility_problem as shared_plausibility


def load_calibration(path):
    """The Calibration in a JSON file; FormatError naming the file and the problem."""
    try:
        with open(path) as fh:
            d = json.load(fh)
    except OSError as exc:
        raise FormatError("%s: %s" % (path, exc.strerror or exc))
    except ValueError as exc:
        raise FormatError("%s: not JSON (%s)" % (path, exc))
    try:
        return Calibration.from_dict(d)
    except ValueError as exc:
        raise FormatError("%s: invalid calibration: %s" % (path, exc))


def save_calibration(path, cal):
    try:
        with open(path, "w") as fh:
            json.dump(cal.to_dict(), fh, indent=2)
            fh.write("\n")
    except OSError as exc:
        raise FormatError("%s: %s" % (path, exc.strerror or exc))


# ****** units and plausibility (fluxcal pull-cal / push-cal / report) ******
# A device's calibration takes ADC codes (docs/protocol.md): meta["units"] says so on the
# files pull-cal writes. A calibration without it takes nT, as `fluxcal fit` writes them.
CODE_UNITS = "codes"


def takes_codes(cal):
    return cal.meta.get("units") == CODE_UNITS


def to_code_units(cal, nT_per_code):
    """A calibration of nT readings h = k n as one of codes n: M K, b / k (K = diag(k))."""
    if takes_codes(cal):
        return cal
    k = [float(v) for v in nT_per_code]
    matrix = [[row[j] * k[j] for j in range(3)] for row in cal.matrix]
    return Calibration(matrix, [b / kj for b, kj in zip(cal.offset, k)], cal.field, cal.diagnostics,
                       dict(cal.meta, units=CODE_UNITS, scale=k), _tempco_scaled(cal.tempco, [1.0 / kj for kj in k]))


def _tempco_scaled(tc, factors):
    """Temperature coefficients for inputs in another unit: the offsets' slopes scale as the
    offsets do (per axis), the gains' are relative and stay."""
    if tc is None:
        return None
    out = dict(tc)
    out["offset_per_c"] = [o * f for o, f in zip(tc["offset_per_c"], factors)]
    return out


def to_nT_units(cal, nT_per_code):
    """A calibration of codes n as one of nT readings h = k n: M K^-1, k b."""
    if not takes_codes(cal):
        return cal
    k = [float(v) for v in nT_per_code]
    matrix = [[row[j] / k[j] for j in range(3)] for row in cal.matrix]
    meta = {key: v for key, v in cal.meta.items() if key != "units"}
    return Calibration(matrix, [b * kj for b, kj in zip(cal.offset, k)], cal.field, cal.diagnostics, meta,
                       _tempco_scaled(cal.tempco, k))


def plausibility_problem(cal):
    """Why a calibration cannot be a sensor's (one line), or None.

    The firmware's own bounds (shared/calibration.py): the same code for the wire and
    the file. from_dict has applied them to every record read; a Calibration built here
    (a fit) is checked before it is written or sent.
    """
    return shared_plausibility(cal)
