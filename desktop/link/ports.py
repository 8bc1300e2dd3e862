"""Which serial port is the handheld: the one MicroPython or CircuitPython board attached.

    choose_port(None)      # the port of the only candidate, else LinkError listing them
    choose_port("COM3")    # as given

Candidates are USB serial ports whose vendor ID belongs to a board that runs
MicroPython or CircuitPython. With none or several attached the error lists
what there is, so the user can pass --port.
"""

from desktop.link import LinkError

# USB vendor IDs of boards that run MicroPython or CircuitPython
BOARD_VENDORS = {
    0x2E8A: "Raspberry Pi (RP2040/RP2350)",
    0x239A: "Adafruit (CircuitPython)",
    0xF055: "MicroPython (pyboard, stm32, samd, ...)",
    0x303A: "Espressif (ESP32-S2/S3/C3 native USB)",
}


def _describe(p):
    vid = "%04x:%04x" % (p.vid, p.pid) if p.vid is not None else "no USB id"
    return "%s (%s, %s)" % (p.device, p.description or "?", vid)


def choose_port(port=None):
    if port:
        return port
    from serial.tools import list_ports

    ports = list(list_ports.comports())
    boards = [p for p in ports if p.vid in BOARD_VENDORS]
    if len(boards) == 1:
        return boards[0].device
    if boards:
        raise LinkError("%d boards attached, pick one with --port: %s"
                        % (len(boards), "; ".join(_describe(p) for p in boards)))
    if ports:
        raise LinkError("no MicroPython/CircuitPython board found by USB id; pick a port with --port: %s"
                        % "; ".join(_describe(p) for p in ports))
    raise LinkError("no serial port found: plug the handheld in (or start `fluxcal emulate`) and pass --port")
