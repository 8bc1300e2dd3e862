"""MicroPython's boot.py (deployed under that name): keep feeding a watchdog the firmware started.

MicroPython runs boot.py after every reset, a soft one too (mpremote makes one at each
step of a deploy), and main.py only after a normal one. A watchdog the firmware
started (the RP2040's, hal_micropython.py) keeps running through a soft reset, but the
timer that fed it while the REPL had the line is gone: keep_watchdog_fed() starts
another, so the REPL keeps the line. Without a running watchdog it does nothing.
"""

try:
    import hal_micropython

    hal_micropython.keep_watchdog_fed()
except Exception:  # noqa: BLE001 - a boot.py that raises keeps MicroPython from running main.py
    pass  # no firmware in lib/ (a deploy half done): the REPL and main.py say so
