"""CircuitPython entry point: the same application on the CircuitPython HAL.

boot.py remounts the flash writable for the firmware (calibration, config,
logs). Hold the button while resetting to stay in the REPL.
"""

import app
import hal_circuitpython

app.start(hal_circuitpython)
