"""Bare-metal MicroPython on an emulated Cortex-M3, driven by mpremote over a pty.

    with QemuBoard(rom="build/rom") as board:      # the folder becomes the board's /rom
        out = board.exec("import bench")           # mpremote connect PORT exec ...
        instructions = 1000 * ticks_us_difference

The board is MicroPython's ports/qemu for ARM's MPS2-AN385 (a Cortex-M3 with
software single-precision floats, a 240 KB heap: a Pico's), built by
desktop/firmware/interpreters.py as "qemu-m3" and run by qemu-system-arm with
`-icount shift=0`: one instruction takes one nanosecond of the board's time, so
`time.ticks_us()` differences times 1000 are instruction counts, repeatable
run to run (../shared/micropython/SOURCE.md).

The board has no writable filesystem. `rom` is built into a ROM filesystem
image (`mpremote romfs build`) that qemu loads at the board's ROMFS partition;
the board mounts it at /rom with /rom/lib on sys.path, and .mpy files there
run in place, as frozen modules do. The board is started afresh for each
QemuBoard, with an empty heap.
"""

import os
import re
import select
import shutil
import subprocess
import sys
import tempfile
import time

from desktop.firmware.interpreters import interpreter

ROMFS_ADDR = "0x21000000"     # MICROPY_HW_ROMFS_PART0_START of boards/MPS2_AN385 (4 MB)
_PTY = re.compile(rb"char device redirected to (/dev/pts/\d+)")


class QemuError(RuntimeError):
    pass


def _mpremote():
    return [sys.executable, "-m", "mpremote"]


class QemuBoard:
    def __init__(self, rom=None, elf=None):
        self.elf = elf or interpreter("qemu-m3")
        if self.elf is None:
            raise FileNotFoundError("qemu-m3 is not built: make interpreters")
        if shutil.which("qemu-system-arm") is None:
            raise FileNotFoundError("qemu-system-arm is missing (Debian's qemu-system-arm)")
        self.rom = rom
        self.proc = None
        self.port = None
        self._tmp = None

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.close()

    def start(self):
        cmd = ["qemu-system-arm", "-M", "mps2-an385", "-nographic", "-monitor", "null", "-semihosting",
               "-icount", "shift=0", "-serial", "pty", "-kernel", self.elf]
        if self.rom is not None:
            self._tmp = tempfile.TemporaryDirectory()
            image = os.path.join(self._tmp.name, "romfs.img")
            r = subprocess.run(_mpremote() + ["romfs", "--no-mpy", "-o", image, "build", self.rom],
                               capture_output=True, text=True)
            if r.returncode:
                raise QemuError("mpremote romfs build: " + (r.stderr or r.stdout).strip().splitlines()[-1])
            cmd += ["-device", "loader,file=%s,addr=%s,force-raw=on" % (image, ROMFS_ADDR)]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        seen = b""
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self.proc.stdout], [], [], 0.2)
            if ready:
                chunk = os.read(self.proc.stdout.fileno(), 4096)
                if not chunk:
                    break
                seen += chunk
                m = _PTY.search(seen)
                if m:
                    self.port = m.group(1).decode()
                    return self
        self.close()
        raise QemuError("qemu-system-arm did not open a pty: %s" % seen.decode(errors="replace").strip())

    def exec(self, code, timeout=600):
        """Run `code` on the board (mpremote exec); its printed output, or QemuError with the traceback."""
        r = subprocess.run(_mpremote() + ["connect", self.port, "exec", code], capture_output=True, text=True,
                           timeout=timeout)
        if r.returncode:
            # the board's traceback comes on stdout, mpremote's own on stderr
            err = r.stdout.strip().splitlines() or r.stderr.strip().splitlines()
            raise QemuError("on the board: " + " | ".join(err[-2:]))
        return r.stdout

    def close(self):
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None
