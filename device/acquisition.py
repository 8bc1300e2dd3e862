"""The DRDY path: boxcar sums in the interrupt handler, a ring, and its reader.

    acq = Acquisition(board, decim=10, window=2)   # config.py's defaults; ring of 128 decimated samples
    board.attach_drdy(acq.isr, rate, acq.account_gap)
    n = acq.poll(on_sample, limit, on_gap)         # main loop: on_sample(sx, sy, sz, st)

Chip 0's frame carries X (CH1) and Y (CH2), chip 1's Z (CH1) and its die
temperature (CH2, MUX=0100). [DS] = ADS1292 datasheet SBAS502C.

`isr` must not allocate: it runs as a hard interrupt on rp2/stm32. It does the
boxcar decimation itself, so the main loop wakes once per decimated sample,
not once per conversion (on a 133 MHz M0+ a main-loop pass costs ~1 ms):
frames before the window of each block of `decim` frames are not read at all
(in RDATAC an unread result is replaced by the next one and DRDY pulses again,
[E2E-915796] in the fact sheet), the `window` frames at the end of the block
are read into preallocated buffers, the status nibble checked, sign-extended
with shifts and summed (|sum| <= window * 2**23 <= 2**29 for window <= 64,
inside the small-int range). A finished block goes into an array('i') ring as
five ints (x, y, z, temperature sums, block number). A full ring drops the
block and counts it; a block with a bad status header is discarded and counted.
Where the board counts DRDY falls in hardware (hal.Board.count_drdy: a PIO state
machine on rp2), the handler runs only on the `window` frames a block reads and
accounts the `decim - window` before them at the first of those (`_shape[2]`).
Where the board has drdy.mpy (device/native/drdy.c) and its HAL a `drdy_bus`,
`isr` is the same handler in C, which the hard IRQ calls without entering the
bytecode VM; `_isr` is the reference, and the handler everywhere else.

Why a short window: a vector averaged over a rotation arc of angle a shrinks by
sin(a/2)/(a/2) ~ 1 - a**2/24; at 1 rev/s a 2.5 ms window biases |B| by
48000 nT * (2*pi*0.0025)**2/24 = 0.49 nT, a 0.1 s window by 1.6 %
(docs/simulator.md). Why decimate by more than the window: the calibration
path costs ~30x the acquisition path per sample, and the fit needs a few
thousand samples, not hundreds of thousands (docs/firmware.md, the sweep).

Continuity: every ring slot carries its block number; the reader counts a
jump (ring overflow, or blocks discarded for a bad frame or a polled-DRDY gap)
in `gaps` and reports it to `on_gap`, so the calibration never compares two
samples that are not neighbours in time.

Polled DRDY (CircuitPython): conversions that come and go while the main loop
is busy never reach `isr`. The HAL measures the time since the last serviced
DRDY and calls `account_gap(frames)` from the main loop before the handler, so
the frame counter and the boxcar phase stay in step with the chip and a boxcar
never sums frames from both sides of a gap. Every completed block number is
accounted for: pushed to the ring, dropped (OVERFLOW) or thrown away
(DISCARDED: a bad header, or a DRDY gap).
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython: const is the identity
    def const(x):
        return x

try:
    # The handler in C (device/native/drdy.c), where deploy installed the board's build
    # (MicroPython; ValueError: a .mpy of another arch or version)
    from drdy import Handler as _NativeHandler
except (ImportError, ValueError):
    _NativeHandler = None
try:
    # poll in C (the same module: drdy.Drain), calling on_sample without a Python frame
    from drdy import Drain as _NativeDrain
except (ImportError, ValueError):
    _NativeDrain = None

FRAME_BYTES = 9              # 24 status bits + 2 x 24-bit channels [DS §8.5.1.5]
_STATUS_MASK = const(0xF0)
_STATUS_SYNC = const(0xC0)   # frame header nibble 1100 [DS §8.5.1.5]

# Ring slots: x, y, z, temperature boxcar sums, block number
SLOTS = const(5)
# State array indices (an array, so the ISR writes without allocating)
# The ring's head (next slot the handler fills) and tail (next the reader takes): equal when empty
HEAD = const(0)
TAIL = const(1)
OVERFLOW = const(2)   # decimated samples dropped because the ring was full
FRAMES = const(3)     # DRDY edges seen (wraps at 2**30)
BADSYNC = const(4)    # frames whose status header was not 1100 (their block is discarded)
_PHASE = const(5)     # position of the next frame in its block, 0..decim-1
_SPOIL = const(6)     # 1 when the open block holds a bad frame
DISCARDED = const(7)  # blocks discarded: a bad frame, or a DRDY gap (account_gap)
BLOCKS = const(8)     # blocks completed (wraps at 2**30): the ring's sequence numbers
MISSED = const(9)     # conversions that passed unseen (polled DRDY): account_gap
LASTBAD = const(10)   # the last bad header: chip << 8 | its first byte (health.py names it)
# The reader's (poll's) own, in the same array: an int there is stored without the attribute
# store's class look-up (~1 k cycles on an RP2040), and drdy.Drain reaches them as words
_SAMPLES = const(11)   # decimated samples delivered by poll (wraps at 2**30)
_GAPS = const(12)      # discontinuities seen in the block numbers (wraps at 2**30)
_LAST = const(13)      # the block number of the sample delivered last, -1: none yet
_NSTATE = const(14)
MAX_WINDOW = const(64)   # window * 2**23 must stay below 2**30 (small int in the ISR)
# Counters wrap from 2**30 - 1 to 0. On a 32-bit port that is the largest small int, so
# the handler compares before it increments: (n + 1) & mask would build 2**30 first, a
# long int, and allocating in a hard IRQ raises MemoryError (tests/micropython/isr_wrap.py).
_WRAP = const(0x3FFFFFFF)


class Acquisition:
    """DRDY handler, ring of decimated samples, and the main loop's reader of it."""

    def __init__(self, board, decim=1, window=1, ring_frames=128, native=True):
        self.board = board
        self._f0 = bytearray(FRAME_BYTES)
        self._f1 = bytearray(FRAME_BYTES)
        # ring_frames decimated samples: 128 hold 1.27 s at 100 samples/s, five
        # times an RP2040's ~0.24 s solve (docs/firmware.md)
        self.ring_frames = ring_frames
        self.ring = array("i", bytes(4 * SLOTS * ring_frames))
        self.state = array("i", bytes(4 * _NSTATE))
        self.acc = array("i", bytes(4 * 4))   # open block: x, y, z, temperature sums
        # decim, decim - window, 1 where the board counts the frames before the window (the
        # handler sees the window's alone): what the native handler reads
        self._shape = array("i", bytes(4 * 3))
        self.counter = None   # "pio" where the board counts them (hal.Board.count_drdy)
        self.set_decimation(decim, window)
        # The handler attach_drdy gets: the native one where the module loads and the HAL hands
        # over its chip selects and SPI read (hal.Board.drdy_bus), else _isr, bound once
        # (creating a bound method inside an ISR allocates).
        bus = getattr(board, "drdy_bus", None)
        if _NativeHandler is not None and bus is not None:
            self.isr = _NativeHandler(self.state, self.acc, self.ring, self._shape, self._f0, self._f1, bus)
            self.handler = "native"
        else:
            self.isr = self._isr
            self.handler = "python"
        # poll in C where drdy.mpy loads (native=False: the class's poll, the reference, as the
        # tests compare them): an instance attribute, found before the method
        if native and _NativeDrain is not None:
            self.poll = _NativeDrain(self)

    def set_decimation(self, decim, window):
        """Boxcar of the last `window` frames of every `decim` (1 <= window <= decim, window <= 64)."""
        if not (1 <= window <= decim and window <= MAX_WINDOW):
            raise ValueError("window %r must be within 1..decim (%r) and <= %d" % (window, decim, MAX_WINDOW))
        self.decim = decim
        self.window = window
        self._first = decim - window
        self._shape[0] = decim
        self._shape[1] = self._first
        # the counter restarts before the counts do: its first interrupt is a window away
        count = getattr(self.board, "count_drdy", None)
        counted = count is not None and self._first > 0 and count(self._first, window)
        self._shape[2] = 1 if counted else 0
        self.counter = "pio" if counted else None
        self.reset()

    def reset(self):
        """Empty ring, zero counters: conversions (re)start (ADS1292Pair.start)."""
        st = self.state
        for i in range(_NSTATE):
            st[i] = 0
        st[_LAST] = -1
        a = self.acc
        for i in range(4):
            a[i] = 0

    @property
    def samples(self):
        """Decimated samples delivered by poll (wraps at 2**30)."""
        return self.state[_SAMPLES]

    @property
    def gaps(self):
        """Discontinuities poll saw in the block numbers (wraps at 2**30)."""
        return self.state[_GAPS]

    @property
    def last_block(self):
        """The block number of the sample poll delivered last (wraps at 2**30; -1: none yet)."""
        return self.state[_LAST]

    @property
    def discarded(self):
        """Blocks thrown away for a bad status header or a DRDY gap (polled DRDY)."""
        return self.state[DISCARDED]

    def status(self):
        """Its part of `status`: the counters of the DRDY path and the ring, which handler and reader run."""
        st = self.state
        return {"frames": st[FRAMES], "overflow": st[OVERFLOW], "missed": st[MISSED], "badsync": st[BADSYNC],
                "discarded": st[DISCARDED], "gaps": self.gaps, "samples": self.samples, "drdy": self.handler,
                "drdy_counter": self.counter,
                # the ring's reader: "native" where drdy.Drain replaced poll (drdy.mpy), else "python"
                "reader": "native" if type(self.poll) is _NativeDrain else "python"}

    # ****** main loop, polled DRDY only ******
    def account_gap(self, frames):
        """`frames` conversions passed unseen (the main loop was busy; polled DRDY).

        Called by a polling HAL from the main loop, before the handler services
        the next conversion; never while `isr` can run (with a hard IRQ nothing
        is missed: the ring absorbs a stall). Advances FRAMES and the boxcar
        phase as `isr` would have, counts `frames` in MISSED, and throws away
        (DISCARDED) every block whose window lost a frame: the open block if the
        gap reaches its window, and every block that ended inside the gap. The
        block numbers still advance, so the reader sees the gap. Integers stay
        below 2**30: `frames` is clipped to 2**29 (4.6 min at 2000 SPS).
        """
        if frames < 1:
            return
        if frames > 0x20000000:
            frames = 0x20000000
        st = self.state
        st[MISSED] = (st[MISSED] + frames) & _WRAP     # main loop: a long int on the way is fine
        st[FRAMES] = (st[FRAMES] + frames) & _WRAP
        end = st[_PHASE] + frames   # position after the gap, from the open block's start
        ends = end // self.decim    # blocks whose last frame (always in the window) was lost
        q = end - ends * self.decim
        if ends:
            st[BLOCKS] = (st[BLOCKS] + ends) & _WRAP
            st[DISCARDED] = (st[DISCARDED] + ends) & _WRAP
            a = self.acc
            a[0] = 0
            a[1] = 0
            a[2] = 0
            a[3] = 0
            # the new open block lost its first q frames: harmless before its window
            st[_SPOIL] = 1 if q > self._first else 0
        elif end > self._first:
            st[_SPOIL] = 1          # the gap reaches into the open block's window
        st[_PHASE] = q

    # ****** interrupt path: no allocation below ******
    def _isr(self, _pin=None):
        # the reference: device/native/drdy.c does the same, word for word (tests/test_native_drdy.py)
        st = self.state
        n = st[FRAMES]
        st[FRAMES] = n + 1 if n != _WRAP else 0
        p = st[_PHASE]
        if p < self._first and self._shape[2]:
            # the board counted the frames before the window: the first of the window's is here
            k = self._first - p
            n = st[FRAMES]
            st[FRAMES] = n + k if n <= _WRAP - k else n - _WRAP - 1 + k
            p = self._first
        q = p + 1
        if q == self.decim:
            q = 0
        st[_PHASE] = q
        if p < self._first:
            return        # outside the boxcar: not read, the next conversion replaces it
        b = self.board
        f0 = self._f0
        f1 = self._f1
        b.spi_readinto(0, f0)
        b.spi_readinto(1, f1)
        a = self.acc
        if (f0[0] & _STATUS_MASK) != _STATUS_SYNC or (f1[0] & _STATUS_MASK) != _STATUS_SYNC:
            n = st[BADSYNC]
            st[BADSYNC] = n + 1 if n != _WRAP else 0
            st[_SPOIL] = 1
            st[LASTBAD] = f0[0] if (f0[0] & _STATUS_MASK) != _STATUS_SYNC else 256 | f1[0]
        else:
            # 24-bit two's complement, MSB first: v - 2**24 when bit 23 is set,
            # with shifts only (written out four times: a call per channel costs
            # more than the arithmetic in a hard IRQ)
            v = (f0[3] << 16) | (f0[4] << 8) | f0[5]
            a[0] += v - ((v & 0x800000) << 1)
            v = (f0[6] << 16) | (f0[7] << 8) | f0[8]
            a[1] += v - ((v & 0x800000) << 1)
            v = (f1[3] << 16) | (f1[4] << 8) | f1[5]
            a[2] += v - ((v & 0x800000) << 1)
            v = (f1[6] << 16) | (f1[7] << 8) | f1[8]
            a[3] += v - ((v & 0x800000) << 1)
        if q:
            return        # block still open
        blk = st[BLOCKS]
        st[BLOCKS] = blk + 1 if blk != _WRAP else 0
        if st[_SPOIL]:
            st[_SPOIL] = 0
            n = st[DISCARDED]
            st[DISCARDED] = n + 1 if n != _WRAP else 0
        else:
            head = st[HEAD]
            nxt = head + 1
            if nxt == self.ring_frames:
                nxt = 0
            if nxt == st[TAIL]:
                n = st[OVERFLOW]
                st[OVERFLOW] = n + 1 if n != _WRAP else 0
            else:
                r = self.ring
                i = head * SLOTS
                r[i] = a[0]
                r[i + 1] = a[1]
                r[i + 2] = a[2]
                r[i + 3] = a[3]
                r[i + 4] = blk
                st[HEAD] = nxt
        a[0] = 0
        a[1] = 0
        a[2] = 0
        a[3] = 0

    # ****** main-loop side of the ring ******
    def available(self):
        """Decimated samples waiting in the ring."""
        st = self.state
        n = st[HEAD] - st[TAIL]
        return n + self.ring_frames if n < 0 else n

    def poll(self, on_sample, limit=16, on_gap=None):
        """Deliver up to `limit` samples from the ring in order; return how many.

        on_sample(sx, sy, sz, st) gets the integer boxcar sums (units: codes x
        window); on_gap(missing) comes first when block numbers jumped (missing: the blocks
        between, 1 for a polled DRDY's usual gap, survey.py Output.gap). The reference of
        drdy.Drain (device/native/drdy.c), which runs instead where the module loads.
        """
        st = self.state
        ring = self.ring
        n = 0
        while n < limit:
            t = st[TAIL]
            if t == st[HEAD]:
                break
            j = t * SLOTS
            sx = ring[j]
            sy = ring[j + 1]
            sz = ring[j + 2]
            stc = ring[j + 3]
            blk = ring[j + 4]
            t += 1
            st[TAIL] = 0 if t == self.ring_frames else t   # slot free: the ISR may reuse it
            t = st[_LAST]
            if t >= 0 and blk != (t + 1 if t != _WRAP else 0):
                j = st[_GAPS]
                st[_GAPS] = j + 1 if j != _WRAP else 0
                if on_gap is not None:
                    on_gap((blk - t - 1) & _WRAP)
            st[_LAST] = blk
            n += 1
            j = st[_SAMPLES]
            st[_SAMPLES] = j + 1 if j != _WRAP else 0
            on_sample(sx, sy, sz, stc)
        return n
