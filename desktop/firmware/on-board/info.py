# Run on a board by `mpremote run` (desktop/firmware/deploy.py): one line saying what
# deploy must know before it copies anything. Not a module of the desktop package.
#   fluxcal-board NAME MPY BLOCK FREE LEFTOVERS
# NAME, MPY: sys.implementation's name and _mpy (0: none); BLOCK, FREE: the filesystem's
# block size and free bytes where the firmware goes (-1: unknown); LEFTOVERS: the staging
# folders an interrupted deploy left, comma-separated, or "-".
import os
import sys

try:
    _s = os.statvfs(".")   # (f_bsize, f_frsize, f_blocks, f_bfree, f_bavail, ...)
    _block, _free = _s[1], _s[1] * _s[4]
except (AttributeError, OSError):
    _block, _free = -1, -1
_left = [d for d in (".fluxcal-new", ".fluxcal-old") if d in os.listdir()]
print("fluxcal-board", sys.implementation.name, getattr(sys.implementation, "_mpy", 0), _block, _free,
      ",".join(_left) or "-")
