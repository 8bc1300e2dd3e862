# Run on a board by `mpremote run` (desktop/firmware/deploy.py): one line saying what
# deploy must know before it copies anything. Not a module of the desktop package.
#   fluxcal-board NAME MPY BLOCK FREE LEFTOVERS FROZEN
# NAME, MPY: sys.implementation's name and _mpy (0: none); BLOCK, FREE: the filesystem's
# block size and free bytes where the firmware goes (-1: unknown); LEFTOVERS: the staging
# folders an interrupted deploy left, comma-separated, or "-"; FROZEN: the FIRMWARE_VERSION of
# a fluxcal firmware frozen into the board's image (make pico-frozen), or "-".
import os
import sys

try:
    _s = os.statvfs(".")   # (f_bsize, f_frsize, f_blocks, f_bfree, f_bavail, ...)
    _block, _free = _s[1], _s[1] * _s[4]
except (AttributeError, OSError):
    _block, _free = -1, -1
_left = [d for d in (".fluxcal-new", ".fluxcal-old") if d in os.listdir()]
# the image's frozen modules alone: a module on the filesystem would answer first
_frozen = "-"
if ".frozen" in sys.path:
    _path = list(sys.path)
    while sys.path:
        sys.path.pop()
    sys.path.append(".frozen")
    try:
        import app   # frozen: its bytecode stays in flash
        _frozen = app.FIRMWARE_VERSION
    except Exception:   # noqa: BLE001 - no frozen fluxcal (ImportError), or another firmware's app
        pass
    sys.path.pop()
    sys.path.extend(_path)
print("fluxcal-board", sys.implementation.name, getattr(sys.implementation, "_mpy", 0), _block, _free,
      ",".join(_left) or "-", _frozen)
