"""A client that opens the virtual handheld's port while the emulator deploys its own firmware over
it is told, in one line, that the board is busy; the deploy goes on undisturbed, and once the
emulator releases the port the same client is answered by the firmware (desktop/devicesim/port_gate.py,
what `fluxcal emulate` holds while it deploys; the emulated Pico's case is in test_pico_laptop.py)."""

import os
import subprocess
import sys
import threading

import pytest

from tests.interpreters import need

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FLUXCAL = os.path.join(os.path.dirname(sys.executable), "fluxcal")
BUSY = "fluxcal: the emulated board is busy deploying its firmware; try again in a moment"


def fluxcal(*args):
    return subprocess.run([FLUXCAL, *map(str, args)], capture_output=True, text=True, cwd=ROOT, timeout=120)


def busy_in_one_line(r):
    return r.returncode == 1 and r.stderr.strip() == BUSY and "Traceback" not in r.stderr


@pytest.mark.parametrize("runtime", ["micropython", "circuitpython"])
def test_a_client_during_the_emulators_deploy_is_told_busy(tmp_path, runtime):
    need(runtime)
    from desktop.devicesim.virtual_handheld import VirtualHandheld
    from desktop.firmware.deploy import MicroPythonDeploy, deploy_drive, firmware_version
    from desktop.link import wait_for_version

    flash = str(tmp_path / "flash")
    with VirtualHandheld(flash, runtime=runtime) as hh:
        own = hh.hold_port("deploying its firmware")
        done = []

        def deploy():            # what fluxcal emulate does on an empty flash, over its own line
            if runtime == "circuitpython":
                deploy_drive(flash)
                hh.act("power-cycle")
            else:
                MicroPythonDeploy(own, compiled=True).run()
            done.append(wait_for_version(own, firmware_version(hh.runtime))["fw"])

        worker = threading.Thread(target=deploy)
        worker.start()
        early = [fluxcal("status", "--port", hh.port)]
        if runtime == "micropython":   # a deploy of one's own, started at the same time
            early.append(fluxcal("deploy", "--port", hh.port))
        worker.join(timeout=300)
        assert done == ["0.1.0"], "the emulator's deploy was disturbed"
        assert all(busy_in_one_line(r) for r in early), [(r.returncode, r.stderr) for r in early]
        r = fluxcal("status", "--port", hh.port)          # still held: the same line
        assert busy_in_one_line(r), r.stderr
        hh.release_port()
        out = fluxcal("status", "--port", hh.port)
        assert out.returncode == 0 and "fluxcal firmware 0.1.0" in out.stdout, out.stdout + out.stderr
