# Runs under each interpreter: the DRDY handler (device/acquisition.py) with its heap locked,
# as a hard IRQ runs it, and every counter and accumulator started just below its wrap
# point; on a 32-bit build an integer past 2**30 - 1 is no small int, and allocating it
# raises MemoryError under the lock. argv[1]: the repository root. Prints one JSON line.
import json
import sys

sys.path[:0] = [sys.argv[1] + "/device", sys.argv[1]]
import micropython  # noqa: E402
import acquisition as A  # noqa: E402

FULL = (1 << 23) - 1          # full-scale codes, so the boxcar sums are as large as they get


class Board:
    """Serves the same full-scale frame from both chips without allocating."""

    def __init__(self):
        f = bytearray(9)
        f[0] = 0xC0           # status header 1100 [DS 8.5.1.5]
        for i in (3, 6):
            f[i] = FULL >> 16
            f[i + 1] = (FULL >> 8) & 0xFF
            f[i + 2] = FULL & 0xFF
        self.frame = f

    def spi_readinto(self, chip, buf):
        f = self.frame
        for i in range(9):
            buf[i] = f[i]


acq = A.Acquisition(Board(), A.MAX_WINDOW, A.MAX_WINDOW, ring_frames=8)
st = acq.state
top = (1 << 30) - 1
for k in (A.FRAMES, A.BADSYNC, A.BLOCKS, A.DISCARDED, A.OVERFLOW, A.MISSED):
    st[k] = top - 2
isr = acq.isr
errors = []
micropython.heap_lock()
try:
    for _ in range(3 * A.MAX_WINDOW):        # three whole blocks: every counter crosses its wrap
        isr(None)
except MemoryError:
    errors.append("MemoryError")
finally:
    micropython.heap_unlock()
got = []
acq.poll(lambda x, y, z, t: got.append([x, y, z, t]), 8)
print(json.dumps({"errors": errors, "frames": st[A.FRAMES], "blocks": st[A.BLOCKS], "samples": got}))
