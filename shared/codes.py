"""The names both ends of the serial line agree on: one module, firmware and laptop import it.

    from shared import codes
    if reply["error"] == codes.BUSY: ...
    raise FitError(codes.NOT_BETTER, "...")

Strings and numbers only, so it runs unchanged on MicroPython, CircuitPython and
CPython. Each group says where its values cross the wire (docs/protocol.md): a
code renamed here is renamed on the device and on the laptop at once.
"""

# ****** the protocol: device/protocol.py frames lines, desktop/link speaks them ******
# The version in every line's "v" and the `version` reply's "proto"; the laptop
# refuses to talk to another.
PROTOCOL_VERSION = 1
# The longest request line the firmware takes, newline not counted: longer ones are
# dropped up to their newline and answered with LINE_TOO_LONG (fluxcal push-cal
# checks its set-cal request against it before sending).
MAX_LINE = 2048

# ****** events: an event line's "ev" (`{"v": 1, "ev": NAME, ...}`), unasked ******
EV_BOOT = "boot"
EV_CAL = "cal"              # a calibration session's progress and its end (state below)
EV_DATA = "data"            # a survey sample, corrected (stream on / corrected)
EV_RAW = "raw"              # a survey sample in ADC codes (stream raw)
EV_ERROR = "error"
EV_FAULT = "fault"          # an ADC fault begins, changes or clears
EV_SAFE_MODE = "safe_mode"
# sent by `fluxcal emulate`, never by the firmware: the emulated board's port is held while the
# emulator deploys and starts its firmware ("msg" says so); desktop/link raises it as BusyError
EV_EMULATOR_BUSY = "emulator_busy"

# ****** the device's state: status's "state" ******
SURVEY = "survey"
CALIBRATING = "calibrating"
# FAULT below is the third.

# ****** error codes: an error reply's "error" (`{"ok": false, "error": CODE, "msg": ...}`) ******
# Framing and the handler's own exception type (device/protocol.py):
LINE_TOO_LONG = "line_too_long"
BAD_ENCODING = "bad_encoding"       # a byte outside ASCII
BAD_REQUEST = "bad_request"         # a control character
UNKNOWN_COMMAND = "unknown_command"
BAD_ARGUMENT = "bad_argument"       # also any ValueError a handler raises
IO_ERROR = "io_error"               # OSError: flash full, file system error
NO_MEMORY = "no_memory"             # MemoryError
INTERNAL_ERROR = "internal_error"   # anything else: a firmware bug, named (also a session's reason)
# Refusals by the commands (device/commands.py, device/calibration_flow.py):
BAD_VALUE = "bad_value"             # config set: a value out of range or of the wrong type
BAD_JSON = "bad_json"               # set-cal: the argument is not JSON
UNKNOWN_KEY = "unknown_key"         # config get/set: no such key
BUSY = "busy"                       # a calibration is running (fluxcal deploy waits on it)
FAULT = "fault"                     # start-cal during an ADC fault (also a session's reason)
NO_CALIBRATION = "no_calibration"   # start-cal quick without a calibration in force; keep-cal with none held
NOT_CALIBRATING = "not_calibrating"  # finish-cal / cancel-cal with no session
NO_COVERAGE = "no_coverage"         # coverage before any calibration since boot

# ****** calibration refusals: the "reason" of a failed `cal` event, of finish-cal's
# result and status's last_cal; set-cal answers the acceptance ones as its error code.
# On the laptop FitError.reason (fluxcal fit, report) carries the fit's ones. ******
# The fit itself (shared/solver.py, iteration.py, result.py, predicted.py; shared/quick.py):
TOO_FEW_SAMPLES = "too_few_samples"
DEGENERATE_COVERAGE = "degenerate_coverage"   # the samples leave the ellipsoid undetermined
NOT_ELLIPSOID = "not_ellipsoid"
NON_FINITE = "non_finite"
NOT_BETTER = "not_better"           # a quick re-calibration no better than the one in force
# The flow (device/calibration_flow.py): a full calibration predicted worse than the one in force,
# which stays; keep-cal puts the new one in force
WORSE_THAN_CURRENT = "worse_than_current"
# The session (device/session.py):
CLIPPED = "clipped"                 # samples at the ADC's full scale
TOO_FAST = "too_fast"               # most samples turned faster than the rate gate
CANCELLED = "cancelled"             # cancel-cal or the button (also the session's state)
# Acceptance (device/acceptance.py; set-cal runs it too):
RMS_TOO_HIGH = "rms_too_high"
POOR_OBSERVABILITY = "poor_observability"
RESPONSE_NOT_FIRST_ORDER = "response_not_first_order"   # de-lagged with the best tau, the residuals follow each other
PREDICTED_ERROR_TOO_HIGH = "predicted_error_too_high"
FIELD_OUT_OF_RANGE = "field_out_of_range"
BAD_SCALE = "bad_scale"

# The acceptance threshold on the predicted full-sphere error, nT: the firmware's
# max_predicted_nt default (device/config.py) and fluxcal fit's --max-predicted default,
# so the laptop refuses what the board would refuse.
MAX_PREDICTED_NT = 5.0

# ****** a calibration session: the `cal` event's and finish-cal's "state" and "kind" ******
COLLECTING = "collecting"
DONE = "done"
FAILED = "failed"
# CANCELLED above is the fourth state.
AUTO = "auto"            # start-cal's default: full, or quick when the coverage stays low
FULL = "full"
QUICK = "quick"
RESHAPED = "reshaped"    # a quick session whose data said the shape moved (shared/quick.py)
