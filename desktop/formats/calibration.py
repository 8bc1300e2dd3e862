"""Calibration records as JSON files: shared.calibration.Calibration.to_dict, indented."""

import json

from desktop.formats import FormatError
from shared.calibration import Calibration


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
