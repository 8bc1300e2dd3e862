"""File formats: what fluxcal reads and writes, and nothing else.

- readings.py: raw readings in nT (a magnetometer log in its unit, or a capture), corrected CSV.
- logtext.py: a log's text split into columns (CSV or whitespace, header or none).
- capture.py: capture files (.npz) of the two ADS1292's codes, as `fluxcal simulate` writes them.
- calibration.py: calibration records (JSON), as `fluxcal fit` writes them.

Every problem with a file is a FormatError whose message is one line naming
the file and what is wrong with it.
"""


class FormatError(Exception):
    """A file that cannot be read or written: one line, `path: what is wrong`."""


def os_problem(path, exc):
    """`path: what is wrong` of an OSError opening it, in the words every reader here uses."""
    if isinstance(exc, FileNotFoundError):
        return "%s: no such file" % path
    if isinstance(exc, IsADirectoryError):
        return "%s: a folder, not a file" % path
    return "%s: %s" % (path, exc.strerror or exc)
