"""The `repl` command: the firmware hands the serial line back to the board's REPL.

On a board the firmware turns Ctrl-C off (micropython.kbd_intr(-1)), so mpremote cannot
interrupt it; `repl` replies, ends the main loop (main.py / code.py returns) and turns
Ctrl-C back on, which is how `fluxcal deploy` redeploys without the button. Shown on the
board HALs in their interpreters over the stand-ins: Ctrl-C is a SIGINT to the unix port,
whose kbd_intr(-1) restores the default action (the process dies) and kbd_intr(3) its
KeyboardInterrupt handler.
"""

import json
import os
import signal

import pytest

from desktop.devicesim.client import Client
from desktop.devicesim.procedure import handheld_config
from desktop.devicesim.runners import BoardDevice, start_device, write_config
from desktop.devicesim.world import make_world
from tests.interpreters import need

# power-on as simboard does it; what follows runs only once main.py / code.py has returned
AFTER_MAIN = """import simboard
simboard.power_on(%r)
print('{"main": "returned"}')
b = simboard.board()
try:
    while True:
        b.idle()        # the board idles in its REPL: the World keeps serving the link
except KeyboardInterrupt:
    print('{"ctrl_c": "KeyboardInterrupt"}')
"""


def _lines(data):
    out = []
    for line in data.decode(errors="replace").splitlines():
        try:
            out.append(json.loads(line))
        except ValueError:
            pass
    return out


BOOT_TXT = os.path.join("%s", "flash", "boot.txt")   # the boot guard's count (bootguard.py)


def _board(tmp_path, interpreter):
    need(interpreter)
    runtime = "circuitpython" if interpreter == "circuitpython" else "micropython"
    w = make_world(serial=None, motion="stationary", seconds=5.0, seed=3)
    write_config(str(tmp_path), **handheld_config(w.scenario, "board:" + interpreter))   # CircuitPython's pin names
    return w, BoardDevice(w, str(tmp_path), interpreter=interpreter, program=AFTER_MAIN % runtime)


@pytest.mark.parametrize("interpreter", ["micropython-float32", "circuitpython"])
def test_repl_returns_the_main_loop_and_turns_ctrl_c_back_on(interpreter, tmp_path):
    w, dev = _board(tmp_path, interpreter)
    try:
        dev.run_until(0.3)
        assert any(d.get("ev") == "boot" for d in _lines(w.out)), w.lines()
        assert os.path.exists(BOOT_TXT % tmp_path)         # a boot not yet healthy (bootguard.py)
        w.send(b"repl\n")
        dev.run_until(0.6)
        seen = _lines(w.out)
        assert {"v": 1, "ok": True, "cmd": "repl"} in seen, w.lines()
        assert {"main": "returned"} in seen, w.lines()   # App.run returned, main.py / code.py ended
        # ended as asked (a deploy follows): not an unfinished boot, however short
        assert not os.path.exists(BOOT_TXT % tmp_path)
        dev.proc.send_signal(signal.SIGINT)              # Ctrl-C
        assert dev.proc.wait(timeout=20) == 0
        rest = os.read(dev.proc.stdout.fileno(), 65536)
        assert {"ctrl_c": "KeyboardInterrupt"} in _lines(rest), rest
    finally:
        dev.close()


def test_ctrl_c_is_off_while_the_firmware_runs(tmp_path):
    """The control: without `repl`, a Ctrl-C cannot raise KeyboardInterrupt in the firmware
    (the unix port takes the signal's default action: the process ends on it)."""
    _, dev = _board(tmp_path, "micropython-float32")
    try:
        dev.run_until(0.3)
        dev.proc.send_signal(signal.SIGINT)
        assert dev.proc.wait(timeout=20) == -signal.SIGINT
    finally:
        dev.close()


def test_repl_is_refused_while_calibrating(tmp_path):
    import serial

    w = make_world(serial="pty", motion="stationary", seconds=5.0, seed=5)
    dev = start_device(w, str(tmp_path), kind="cpython")
    try:
        dev.run_until(0.3)
        with serial.Serial(w.serial_port, timeout=1, exclusive=True) as ser:
            c = Client(ser, dev)
            assert "repl" in c.ask("help")["commands"]
            assert c.ask("start-cal")["ok"]
            r = c.ask("repl")
            assert r["ok"] is False and r["error"] == "busy"
            assert c.ask("cancel-cal")["ok"]
            assert c.ask("repl")["ok"]
    finally:
        dev.close()
