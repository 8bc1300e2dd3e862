"""MicroPython entry point. Hold the button while powering up to stay in the REPL."""

import app
import hal_micropython

app.start(hal_micropython)
