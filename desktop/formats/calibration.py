"""Calibration records as JSON files: shared.calibration.Calibration.to_dict, indented."""

import json

from desktop.formats import FormatError, os_problem
from shared.calibration import Calibration, plausibility_problem as shared_plausibility


def load_calibration(path):
    """The Calibration in a JSON file; FormatError naming the file and the problem."""
    try:
        with open(path) as fh:
            d = json.load(fh)
    except OSError as exc:
        raise FormatError(os_problem(path, exc))
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
    out = cal.scaled_input([1.0 / kj for kj in k])
    out.meta = dict(cal.meta, units=CODE_UNITS, scale=k)
    return out


def to_nT_units(cal, nT_per_code):
    """A calibration of codes n as one of nT readings h = k n: M K^-1, k b."""
    if not takes_codes(cal):
        return cal
    out = cal.scaled_input([float(v) for v in nT_per_code])
    out.meta = {key: v for key, v in cal.meta.items() if key != "units"}
    return out


def plausibility_problem(cal):
    """Why a calibration cannot be a sensor's (one line), or None.

    The firmware's own bounds (shared/calibration.py): the same code for the wire and
    the file. from_dict has applied them to every record read; a Calibration built here
    (a fit) is checked before it is written or sent.
    """
    return shared_plausibility(cal)
