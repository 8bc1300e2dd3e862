"""Which serial port is the handheld: the one MicroPython or CircuitPython board attached.

    choose_port(None)      # the port of the only candidate, else LinkError listing them
    choose_port("COM3")    # as given
    emulator_on(port)      # the running `fluxcal emulate` on that port ({"pid", "runtime", ...}) or None

Candidates are USB serial ports whose vendor ID belongs to a board that runs
MicroPython or CircuitPython. With none attached, a running `fluxcal emulate`
is one: it leaves its port in a file of the user's runtime folder
($XDG_RUNTIME_DIR/fluxcal, else fluxcal-UID in the temporary folder) while it
runs (announce_emulator). With none or several the error lists what there is,
so the user can pass --port.
"""

import json
import os
import tempfile

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


def runtime_folder():
    """Where running emulators leave their ports: the user's own, not shared with other users."""
    base = os.environ.get("XDG_RUNTIME_DIR")
    if base and os.path.isdir(base):
        return os.path.join(base, "fluxcal")
    return os.path.join(tempfile.gettempdir(), "fluxcal-%d" % os.getuid())


def announce_emulator(port, runtime):
    """Leave this process's emulator port where choose_port looks; the path, to remove at exit."""
    folder = runtime_folder()
    os.makedirs(folder, mode=0o700, exist_ok=True)
    path = os.path.join(folder, "emulate-%d.json" % os.getpid())
    with open(path + ".tmp", "w") as fh:    # whole or not at all: a reader never sees half a file
        json.dump({"port": port, "pid": os.getpid(), "runtime": runtime}, fh)
    os.replace(path + ".tmp", path)
    return path


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:     # someone else's process took the number: not ours
        return False
    return True


def running_emulators():
    """[{"port", "pid", "runtime"}] of the emulators running now (files of ended ones are removed)."""
    folder = runtime_folder()
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        return []
    out = []
    for name in names:
        if not (name.startswith("emulate-") and name.endswith(".json")):
            continue
        path = os.path.join(folder, name)
        try:
            with open(path) as fh:
                emu = json.load(fh)
            pid, port = int(emu["pid"]), str(emu["port"])
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if _alive(pid) and os.path.exists(port):
            out.append(emu)
        else:       # killed without its clean-up: forget it
            try:
                os.remove(path)
            except OSError:
                pass
    return out


def emulator_on(port):
    """The running emulator whose port this is, or None."""
    return next((e for e in running_emulators() if e["port"] == port), None)


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
    emulators = running_emulators()
    if len(emulators) == 1:
        return emulators[0]["port"]
    if emulators:
        raise LinkError("no board attached and %d emulators running, pick one with --port: %s"
                        % (len(emulators), "; ".join("%s (fluxcal emulate, pid %d)" % (e["port"], e["pid"])
                                                     for e in emulators)))
    if ports:
        raise LinkError("no MicroPython/CircuitPython board found by USB id and no fluxcal emulate running;"
                        " pick a port with --port: %s"
                        % "; ".join(_describe(p) for p in ports))
    raise LinkError("no serial port found: plug the handheld in (or start `fluxcal emulate`) and pass --port")
