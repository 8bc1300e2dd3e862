# Runs under CPython (the pure-Python handler alone: the reference) and each MicroPython board
# (with drdy.Handler where drdy.mpy loads), from argv or main(root, natmod_folder): puts the
# folder holding drdy.mpy and the repository's device/ on sys.path and feeds Acquisition's two
# DRDY handlers the same conversions. Every scenario runs twice on the interpreter: once with
# the pure-Python _isr (a board without drdy_bus), once with the native handler where it loads
# (a board with drdy_bus); after every conversion their state, acc and ring arrays and the
# order of the bus calls (cs0 low, read, cs0 high, cs1 low, read, cs1 high) must be the same.
# Frames come from a fixed 32-bit LCG (lcg.py beside it, not `random`): random codes and the +-2**23 extremes,
# bad status headers on either chip, counters started near the 2**30 wrap, a small ring read
# now and then (so it fills and overflows), account_gap and set_decimation between
# conversions, decim/window combinations with window == decim and window 1. Then the board
# counts the frames before the window (hal.Board.count_drdy, a PIO counter on rp2): the handlers
# run on the window's conversions alone, and after each of them their arrays must be those of a
# handler fed every conversion (`lagged`: the conversions where they were not). Prints one line
# per scenario (its final arrays and a checksum of every intermediate one, as the pure-Python
# handler gives them: compared with CPython's), then one JSON line: the handler's path, the
# conversions where the two handlers differed, and what the heap-locked run raised.
import gc
import json
import sys

TOP = 1 << 23
WRAP = (1 << 30) - 1
# (decim, window, ring_frames, conversions)
SCENARIOS = ((10, 2, 4, 700), (10, 10, 3, 300), (1, 1, 4, 200), (64, 64, 8, 400), (64, 1, 2, 500),
             (7, 3, 5, 400), (2, 1, 1, 60), (3, 2, 16, 300))
# the board counting: (decim, window, ring_frames, conversions); mid-run a boxcar of
# window == decim (nothing counted), then the first again
COUNTED = ((10, 2, 4, 500), (64, 1, 2, 400), (7, 3, 5, 300))


class Board:
    """Serves preset frames in turn through spi_readinto (the pure-Python handler) and, with
    `bus`, through drdy_bus (the native one), logging the calls into a preallocated bytearray."""

    def __init__(self, frames, bus, counts=False):
        self.frames = frames          # 18 bytes a conversion: chip 0's frame, chip 1's
        self.counts = counts          # counts the frames before the window (count_drdy)
        self.k = 0                    # the next conversion's frame pair
        self.chip = 0
        self.log = bytearray(len(frames) // 3)     # six calls a conversion read
        self.n = 0
        if bus:
            self.drdy_bus = [self.cs0, self.cs1, self.readinto]

    def count_drdy(self, skip, window):
        return self.counts

    def _note(self, what):
        self.log[self.n] = what
        self.n += 1

    def cs0(self, level):
        self.chip = 0
        self._note(0x10 | level)

    def cs1(self, level):
        self.chip = 1
        self._note(0x20 | level)

    def readinto(self, buf, fill):
        f = self.frames
        o = 18 * self.k + 9 * self.chip
        for i in range(9):
            buf[i] = f[o + i]
        self._note(0x40 | self.chip | (fill << 1))
        if self.chip:
            self.k += 1

    def spi_readinto(self, chip, buf):   # as hal_micropython.Board.spi_readinto does
        cs = self.cs1 if chip else self.cs0
        cs(0)
        self.chip = chip
        self.readinto(buf, 0)
        cs(1)


def frame(f, rng, codes, header0, header1):
    f[0] = header0
    f[9] = header1
    for j in range(4):
        v = codes[j] & 0xFFFFFF
        o = (3, 6, 12, 15)[j]
        f[o] = v >> 16
        f[o + 1] = (v >> 8) & 0xFF
        f[o + 2] = v & 0xFF
    f[1] = rng.bits(8)       # the rest of the status word: never looked at


def frames(rng, n):
    out = bytearray(18 * n)
    edges = (-TOP, TOP - 1, 0, -1, 1)
    for i in range(n):
        r = rng.bits(4)
        if r == 0:
            codes = [edges[rng.bits(3) % 5] for _ in range(4)]
        else:
            codes = [rng.bits(24) - TOP for _ in range(4)]
        h0 = h1 = 0xC0 | rng.bits(4)          # sync nibble 1100, the low nibble free
        if rng.bits(5) == 0:                  # ~3 %: a bad header on one chip or both
            which = rng.bits(2)
            bad = rng.bits(8)
            while bad & 0xF0 == 0xC0:
                bad = rng.bits(8)
            if which & 1:
                h0 = bad
            if which & 2 or which == 0:
                h1 = bad
        frame(memoryview(out)[18 * i:], rng, codes, h0, h1)
    return out


def setup(A, decim, window, ring_frames, fs, plan, native, counts=False):
    board = Board(fs, native, counts)
    acq = A.Acquisition(board, decim, window, ring_frames)
    for k in (A.FRAMES, A.BADSYNC, A.BLOCKS, A.DISCARDED, A.OVERFLOW):
        acq.state[k] = WRAP - plan[0] - k
    return acq, board


def step(acq, i, plan, got):
    """Conversion i: a polled gap or a new boxcar first where the plan says, the handler, a read."""
    if i in plan[1]:
        acq.account_gap(plan[1][i])
    if i in plan[2]:
        d, w = plan[2][i]
        acq.set_decimation(d, w)
    acq.isr(None)
    if i % plan[3] == 0:
        acq.poll(lambda x, y, z, t: got.append((x, y, z, t)), 2)


def step_counted(acq, i, plan, got, read):
    """Conversion i where the board counts: a new boxcar where the plan says (the counter
    restarts with it), the handler only where the conversion is `read`, a read of the ring."""
    if i in plan[2]:
        acq.set_decimation(*plan[2][i])
    if read:
        acq.isr(None)
    if i % plan[3] == 0:
        acq.poll(lambda x, y, z, t: got.append((x, y, z, t)), 2)


def counted(A, rng, native, short):
    """COUNTED's scenarios: lines as main's, and the conversions where a handler differed."""
    differed = 0
    lines = []
    for s, (decim, window, ring_frames, n) in enumerate(COUNTED):
        n = n // 2 if short else n
        every = acq = twin = fs = got = None
        gc.collect()          # the last scenario's frames go first: Cortex-M3's heap is small
        fs = frames(rng, n)
        plan = (s, {}, {n // 3: (5, 5), 2 * n // 3: (decim, window)}, 3 + s)
        every = setup(A, decim, window, ring_frames, fs, plan, False)[0]     # fed every conversion
        acq = setup(A, decim, window, ring_frames, fs, plan, False, True)[0]
        twin = setup(A, decim, window, ring_frames, fs, plan, True, True)[0] if native else None
        got = ([], [], [])
        h = 0
        lagged = 0
        d, w, phase = decim, window, 0
        for i in range(n):
            if i in plan[2]:
                d, w = plan[2][i]
                phase = 0                 # the counter restarts: its next fall is a block's first
            read = phase >= d - w
            phase = phase + 1 if phase + 1 < d else 0
            step(every, i, plan, got[0])
            step_counted(acq, i, plan, got[1], read)
            h = checksum(h, acq)
            if twin is not None:
                step_counted(twin, i, plan, got[2], read)
                if not same(acq, twin):
                    differed += 1
            if not same(acq, every):
                lagged += 1
                if read:
                    differed += 1         # after a read the counted handler has caught up
        if acq._shape[2] != 1 or acq.counter != "pio" or got[1] != got[0] or (twin is not None and got[2] != got[0]):
            differed += 1
        lines.append(json.dumps([decim, window, "counted", lagged, list(acq.state), list(acq.ring), got[1][-3:], h]))
    return lines, differed


def checksum(h, acq):
    for part in (acq.state, acq.acc, acq.ring):
        for v in part:
            h = (h * 31 + (v & 0xFFFFFFFF)) & 0xFFFFFFFF
    return h


def same(a, b):
    return a.state == b.state and a.acc == b.acc and a.ring == b.ring


def heap_locked(A, Rand):
    """The native handler with the heap locked, as a hard IRQ runs it: counters just below the
    wrap, full-scale frames filling the largest boxcar; what it raised."""
    import micropython
    full = [TOP - 1] * 4
    rng = Rand(3)
    fs = bytearray(18 * 3 * A.MAX_WINDOW)
    for i in range(3 * A.MAX_WINDOW):
        frame(memoryview(fs)[18 * i:], rng, full, 0xC0, 0xC0)
    board = Board(fs, True)
    acq = A.Acquisition(board, A.MAX_WINDOW, A.MAX_WINDOW, 8)
    for k in (A.FRAMES, A.BADSYNC, A.BLOCKS, A.DISCARDED, A.OVERFLOW):
        acq.state[k] = WRAP - 2
    isr = acq.isr
    errors = []
    micropython.heap_lock()
    try:
        for _ in range(3 * A.MAX_WINDOW):
            isr(None)
    except MemoryError:
        errors.append("MemoryError")
    finally:
        micropython.heap_unlock()
    got = []
    acq.poll(lambda x, y, z, t: got.append(x == y == z == t == A.MAX_WINDOW * (TOP - 1)), 8)
    return errors, got == [True] * 3, acq.state[A.FRAMES]


def main(root, natmod=None, short=None):
    if short is None:     # a board (rp2, qemu: a few MHz of emulation): every scenario half as long
        short = sys.platform not in ("linux", "darwin", "win32")
    for folder in (root + "/device", root + "/tests/micropython", natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    import acquisition as A
    from lcg import Rand

    cpython = sys.implementation.name == "cpython"
    native = A._NativeHandler is not None
    rng = Rand(19)
    differed = 0
    for s, (decim, window, ring_frames, n) in enumerate(SCENARIOS):
        n = n // 2 if short else n
        acq = twin = board = fs = got = got2 = None
        gc.collect()          # the last scenario's frames go first: Cortex-M3's heap is small
        fs = frames(rng, n)
        gaps = {}
        shapes = {}
        for _ in range(3):
            gaps[rng.bits(16) % n] = 1 + rng.bits(6)
        if s == 0:
            shapes[n // 2] = (5, 5)
            shapes[3 * n // 4] = (10, 2)
        plan = (s, gaps, shapes, 3 + s)
        acq, board = setup(A, decim, window, ring_frames, fs, plan, False)
        twin = setup(A, decim, window, ring_frames, fs, plan, True) if native else None
        got = []
        got2 = []
        h = 0
        for i in range(n):
            step(acq, i, plan, got)
            h = checksum(h, acq)
            if twin is not None:
                step(twin[0], i, plan, got2)
                if not same(acq, twin[0]):
                    differed += 1
        if twin is not None:
            assert twin[0].handler == "native" and acq.handler == "python"
            if got != got2 or board.log[:board.n] != twin[1].log[:twin[1].n]:
                differed += 1
        print(json.dumps([decim, window, list(acq.state), list(acq.acc), list(acq.ring), got[-3:], h]))
    acq = twin = board = fs = got = got2 = None
    lines, d = counted(A, rng, native, short)
    differed += d
    for line in lines:
        print(line)
    gc.collect()
    locked = heap_locked(A, Rand) if native and not cpython else None
    print(json.dumps({"path": "native" if native else "python", "differed": differed, "heap_locked": locked}))


if __name__ == "__main__" and len(sys.argv) > 2:    # a board without argv imports it and calls main()
    main(sys.argv[1], sys.argv[2] or None, len(sys.argv) > 3 and sys.argv[3] == "short")
