"""FitError: a calibration the core refuses, with a stable reason (shared/codes.py).

    try:
        cal = fit.solve()
    except FitError as exc:
        exc.reason, exc.message   # "degenerate_coverage", "samples span no volume: rotate ..."

The reasons cross the wire as a failed calibration's "reason" (docs/protocol.md).
"""


class FitError(Exception):
    """A calibration that cannot be trusted; .reason is a stable code."""

    def __init__(self, reason, message):
        super().__init__("%s: %s" % (reason, message))
        self.reason = reason
        self.message = message
