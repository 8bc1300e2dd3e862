"""The laptop's end of the serial line: the firmware's protocol over pyserial (docs/protocol.md).

    from desktop.link import open_device
    dev = open_device(None)              # the one MicroPython/CircuitPython board attached, or a port
    dev.info                             # the `version` reply: fw, proto, runtime, impl
    dev.ask("status")                    # the reply's fields; DeviceError for an error reply
    dev.ask("stream on corrected")
    ev = dev.next_event(timeout=1.0)     # {"v": 1, "ev": "data", ...} or None
    dev.close()

- ports.py: which port (auto-detection by USB vendor, or the list to choose from).
- lines.py: bytes in, protocol lines out; noise and broken lines skipped and counted.
- gps.py: a GPS receiver on a second port (NMEA by pynmea2), for `fluxcal survey --gps`.
- client.py: the Device: requests and replies with a deadline on every read, events
  kept apart, the protocol version checked on connect.

Every failure is a LinkError whose message is one line a person can act on.
"""


class LinkError(Exception):
    """The device cannot be reached or understood: one line, for a person."""


class BusyError(LinkError):
    """`fluxcal emulate` holds its board's port while it deploys and starts the firmware."""


class DeviceError(LinkError):
    """The device answered a request with an error reply; .code is its stable code."""

    def __init__(self, command, code, msg):
        super().__init__("the device refused %s: %s (%s)" % (command, msg, code))
        self.command = command
        self.code = code


def open_device(port=None, timeout=2.0):
    """Open `port` (None: auto-detect) and check the firmware's protocol version."""
    from desktop.link.client import Device
    from desktop.link.ports import choose_port

    dev = Device(choose_port(port), timeout=timeout)
    try:
        dev.connect()
    except BaseException:
        dev.close()
        raise
    return dev


def wait_for_version(port, expected, wait_s=20.0):
    """Wait until the firmware on `port` answers `version` (after a reset the port may come and go);
    its reply, or LinkError when it is not `expected` or nothing answered within wait_s."""
    import time

    deadline = time.monotonic() + wait_s
    last = "nothing answered"
    while time.monotonic() < deadline:
        try:
            dev = open_device(port, timeout=1.0)
        except LinkError as exc:
            last = str(exc)
            time.sleep(0.2)
            continue
        dev.close()
        if dev.info.get("fw") != expected:
            raise LinkError("the board on %s runs firmware %s, not the %s just deployed"
                            % (port, dev.info.get("fw"), expected))
        return dev.info
    raise LinkError("the firmware did not answer `version` on %s within %g s of the deploy: %s"
                    % (port, wait_s, last))
