"""CircuitPython boot.py: give the firmware write access to CIRCUITPY.

CIRCUITPY is writable either by the USB host or by code, never both. The
firmware must write cal.json, config.json and logs, so the filesystem is
remounted writable for code here -- unless the button (config pin, default
GP15, active low) is held during reset: then the USB host keeps write access
(for copying new firmware), and the calibration cannot be saved until the next
normal reset. MicroPython ignores this file's contents (no `storage` module
there has remount; its filesystem is always writable by code).

usb_cdc.enable(data=True) adds a second, binary-clean serial port for the
protocol; the console port keeps the REPL.
"""

try:
    import board
    import digitalio
    import storage
    import usb_cdc

    usb_cdc.enable(console=True, data=True)
    pin = digitalio.DigitalInOut(getattr(board, "GP15", None) or board.BUTTON)
    pin.switch_to_input(pull=digitalio.Pull.UP)
    if pin.value:   # not pressed
        storage.remount("/", readonly=False)
    pin.deinit()
except (ImportError, AttributeError):
    pass  # MicroPython, or a board without these pins
