"""What a board sends on an open serial port until a marker: the tests' one way to wait for a line."""

import time


def read_until(ser, marker, timeout):
    """Bytes read from `ser` (an open pyserial port) until `marker` is among them or `timeout`
    wall seconds pass; the caller checks which."""
    buf = b""
    end = time.monotonic() + timeout
    while marker not in buf and time.monotonic() < end:
        buf += ser.read(4096)
    return buf
