# Stand-in for CircuitPython's `storage` module, from docs.circuitpython.org shared-bindings/storage:
# remount(mount_path, readonly=False, *, disable_concurrent_write_protection=False), which only
# boot.py may call; the filesystem is the flash folder the interpreter runs in. Not a module of
# the desktop package.
import simboard

_board = simboard.board()
writable_by_code = False


def remount(mount_path, readonly=False, *, disable_concurrent_write_protection=False):
    global writable_by_code
    if _board.phase != "boot":
        raise RuntimeError("Cannot remount '/' when visible via USB.")
    if mount_path != "/":
        raise OSError(22, "not a mount point")
    writable_by_code = not readonly
