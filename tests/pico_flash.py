"""The emulated Pico's flash file made on the host, with files already in its filesystem (the
tests' set-up; littlefs-python is a test dependency, not the wheel's).

    from tests.pico_flash import flash_with
    flash_with("out/pico.flash", "out/disk")     # out/disk/* at /disk on the board
    with PicoBoard("out/pico.flash") as board:    # boots with them in place
        ...

What `mpremote cp -r out/disk :` would leave on a freshly formatted board, without its cost: mpremote
writes a file as Python statements of 256 bytes each that the board compiles (about a million cycles
a chunk on the emulated RP2040, ~7 s of the host's time for 60 KB), which is a test's set-up, not
what it tests. The users' paths (`fluxcal deploy`, the README) still copy through mpremote.

The layout is the rp2 port's for RPI_PICO, as desktop/devicesim/pico/runner.mjs has it: a 2 MiB
flash file, littlefs v2 from 0xa0000 in 4 KiB blocks to the end, formatted as ports/rp2/modules/
_boot.py formats it (vfs.VfsLfs2.mkfs(rp2.Flash(), progsize=256)). littlefs-python carries the same
littlefs (v2.11, disk version 2.1) as MicroPython 1.28's lib/littlefs.
"""

import os

FLASH_SIZE = 2 * 1024 * 1024
FS_OFFSET = 0xA0000
FS_BLOCK = 4096


def flash_with(flash_file, folder, at="/disk"):
    """Write `flash_file`: an erased 2 MiB flash whose filesystem holds `folder`'s tree at `at`
    (the firmware region is left erased: the runner writes its image there at each start)."""
    from littlefs import LittleFS

    fs = LittleFS(block_size=FS_BLOCK, block_count=(FLASH_SIZE - FS_OFFSET) // FS_BLOCK,
                  prog_size=256, read_size=32, lookahead_size=32)
    for top, dirs, files in os.walk(folder):
        dirs.sort()
        there = (at.rstrip("/") + "/" + os.path.relpath(top, folder)).replace("/.", "") or "/"
        if there != "/":
            fs.makedirs(there, exist_ok=True)
        for name in sorted(files):
            with open(os.path.join(top, name), "rb") as src, fs.open(there.rstrip("/") + "/" + name, "wb") as dst:
                dst.write(src.read())
    image = bytearray(b"\xff" * FLASH_SIZE)
    image[FS_OFFSET:] = fs.context.buffer
    with open(flash_file, "wb") as f:
        f.write(image)
