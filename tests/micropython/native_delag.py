# Runs under CPython (the pure-Python push alone: the reference) and each MicroPython/CircuitPython board
# (with the native push where delagc.mpy loads), from argv or main(root, natmod_folder): puts
# the folder holding delagc.mpy and the repository (shared/) on sys.path and pushes the same
# samples through two of shared/delag.py's Delags, Delag(..., native=False) (the reference) and
# Delag (native where the module loads). After every push the result, the outputs (x, y, z, t,
# ex, ey, ez), the saturation count and the whole state (_n, _h) must be the same.
# Samples come from a fixed 32-bit LCG (lcg.py beside it): a turning field with noise, steps and
# gaps (reset) and one-sample gaps bridged (join), random sums over the whole range, the +-2**23 * window extremes in every
# combination (saturation), taus from 1 us to past the words (shift 1, num past 2**27), tau
# steps on and off, set_taus switching mid-stream, and numbers set by hand past the native
# words (coefficients, limits, the count, sums beyond a small int); every window (1 .. 64) and
# decimation (1 .. 256) kind the config allows, at rates 125 .. 8000. Prints one line per
# scenario (the reference's counts and a checksum of every result and state: compared with
# CPython's), then one JSON line: the path, the pushes where the two differed, the pushes the
# native push handed to Python in scenario 0 (a smooth stream: only the four filling the
# history) and in all, and what a smooth stream with tau steps pushed with the heap locked raised.
import gc
import json
import sys

MASK = 0x3FFFFFFF
# (rate, decim, window, taus_us, steps_us, stream, samples)
SCENARIOS = ((1000, 10, 2, (31831, 31831, 31831), None, "smooth", 400),
             (1000, 10, 2, (31839, 725, 160), (3000, 500, 0), "hand", 800),
             (8000, 1, 1, (1, 2, 3), (1, 0, 3), "hand", 300),
             (125, 256, 64, (725, 725, 725), None, "hand", 300),
             (1000, 64, 64, (725, 31831, 7), (700, 1, 7), "random", 400),
             (1000, 64, 64, (2000000, 31831, 7), (1999999, 1, 7), "random", 200),
             (8000, 1, 1, (10000000, 10000000, 10000000), (5000000, 0, 10000000), "random", 300),
             (125, 1, 1, (40000000000, 1, 2), None, "hand", 200),     # shift 1, num past the words
             (1000, 64, 64, (31831, 31831, 31831), (31831, 31831, 31831), "edges", 0),
             (2000, 4, 1, (725, 31831, 725), (700, 1, 0), "edges", 0),
             (1000, 10, 2, (31831, 725, 31831), (1000, 700, 0), "switch", 600),
             (1000, 10, 2, (31831, 31831, 31831), (3000, 3000, 3000), "tampered", 700),
             (1000, 10, 2, (31831, 725, 31831), (3000, 700, 0), "bridged", 600))


def samples(rng, kind, window, n, short=False):
    """(x, y, z, t) window sums, None for a gap."""
    full = window << 23
    if kind == "edges":
        edges = (-full, full - 1, 0, full >> 1, -1)
        for x in edges:
            for y in edges:
                for z in edges:
                    # five pushes a combination (three on a board)
                    for w in ((full - 1, -full, 0) if short else (full - 1, -full, 0, -full, full - 1)):
                        yield (x, w, z, y) if w else (x, y, z, y)
        return
    p = [3000000 * window, -1500000 * window, 800000 * window]
    bits = 10 if kind == "smooth" else 14
    v = [rng.signed(bits) * window, rng.signed(bits) * window, rng.signed(bits - 2) * window]
    for i in range(n):
        if kind == "random":
            yield rng.signed(23) * window, rng.signed(23) * window, rng.signed(23) * window, i
            continue
        for a in range(3):
            v[a] += rng.signed(bits - 6) * window
            if not -full // 2 < p[a] + v[a] < full // 2:
                v[a] = -v[a]
            p[a] += v[a]
        s = [p[0] + rng.signed(5), p[1] + rng.signed(5), p[2] + rng.signed(5), 2000 + i]
        r = 99 if kind == "smooth" else rng.bits(6)
        if kind == "bridged":
            if i % 9 in (0, 2):
                yield None      # a polled board's one-sample gaps (runs of 6 and 1): joined
            yield tuple(s)
            continue
        if r < 2:
            p[rng.bits(2) % 3] += rng.signed(22) * window   # a step that stays
        elif r == 2:
            yield None
        yield tuple(s)


def state(dl):
    return [dl.x, dl.y, dl.z, dl.t, dl.ex, dl.ey, dl.ez, dl.saturated, dl._n] + [v for s in dl._h for v in s]


def checksum(h, good, st):
    h = (h * 31 + (2 if good else 1)) & MASK
    for v in st:
        h = (h * 31 + (-7 if v is None else v & 0xFFFFFFF)) & MASK
    return h


def tamper(dl, i):
    """Numbers past the native words (and a small int's), set by hand after set_taus undid the last."""
    j = i // 50 % 7
    if j in (1, 2, 5):
        dl.set_taus(dl.taus_us, 1000, 10, [3000, 3000, 3000])
    if j == 1:
        dl._k[0] = 1 << 27                  # num past the words
    elif j == 2:
        dl._lim[1] = (1 << 28) + 1          # a limit past them
    elif j == 3:
        dl.saturated = (1 << 30) - 1        # the count at a 32-bit port's small int's end
    elif j == 4:
        dl.saturated = 1 << 62
    elif j == 5:
        dl._h[2][1] = 1 << 31               # a held sum past the words
    elif j == 6:
        dl._h[3][2] = 1 << 40               # a held sum past a 32-bit port's small int


def heap_locked(D, Rand):
    """A smooth stream with tau steps through the native de-lag with the heap locked: what it raised."""
    import micropython
    rng = Rand(5)
    dl = D.Delag(2)
    ref = D.Delag(2, native=False)
    for d in (dl, ref):
        d.set_taus([31831] * 3, 1000, 10, [3000] * 3)
    pushes = [None] * 120
    good = [0] * len(pushes)
    for i, s in enumerate(samples(rng, "smooth", 2, len(pushes))):
        pushes[i] = s
        good[i] = ref.push(s[0], s[1], s[2], s[3])
    push = dl.push
    for i in range(4):          # the history's four in Python, first
        push(pushes[i][0], pushes[i][1], pushes[i][2], pushes[i][3])
    same = 4
    errors = []
    micropython.heap_lock()
    try:
        for i in range(4, len(pushes)):
            s = pushes[i]
            if push(s[0], s[1], s[2], s[3]) == good[i]:
                same += 1
    except MemoryError:
        errors.append("MemoryError")
    finally:
        micropython.heap_unlock()
    return errors, same == len(pushes) and state(dl) == state(ref)


def sizes(short):
    """SCENARIOS' sample counts; short (the emulated boards, at a few MHz of emulation): a quarter
    of each stream's, but all six of the switch's phases and two of the tampered's oversized sums."""
    if not short:
        return [sc[6] for sc in SCENARIOS]
    return [sc[6] if sc[5] == "switch" else 400 if sc[5] == "tampered" else sc[6] // 4 for sc in SCENARIOS]


def main(root, natmod=None, short=None):
    if short is None:
        short = sys.platform not in ("linux", "darwin", "win32")    # a board: rp2, qemu
    for folder in (root, root + "/tests/micropython", natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    from shared import delag as D
    from lcg import Rand

    native = D._NativePush is not None
    slow = [0]

    def counting(dl):
        """The native de-lag, counting the pushes it hands to Python."""
        def python_push(self, x, y, z, t):
            slow[0] += 1
            return D.Delag.push(self, x, y, z, t)
        dl.push = dl._fast = D._NativePush(dl, python_push)   # reset and a bridge go back to it

    locked = heap_locked(D, Rand) if native else None
    gc.collect()
    rng = Rand(23)
    differed = 0
    slow0 = None
    handed = 0          # the pushes the native push handed to Python, every scenario
    total = 0
    for s, (rate, decim, window, taus, steps, kind, _) in enumerate(SCENARIOS):
        n = sizes(short)[s]
        gc.collect()
        ref = D.Delag(window, native=False)
        twin = D.Delag(window) if native else None
        both = (ref,) if twin is None else (ref, twin)
        for d in both:
            d.set_taus(list(taus), rate, decim, None if steps is None else list(steps))
        if native:
            counting(twin)
        slow[0] = 0
        h = 0
        pushes = 0
        held = None         # "bridged": the sample before a hole is pushed after join
        for i, smp in enumerate(samples(rng, kind, window, n, short)):
            if kind == "bridged":
                if smp is None:
                    for d in both:
                        if d.can_join():
                            d.join(True)
                        else:
                            d.reset()
                smp, held = held, smp
                if smp is None:
                    continue
            if kind == "switch" and i % 100 == 0:
                # tau steps on and off, de-lag off and on (a reset), other taus
                tt = (list(taus), list(taus), None, [725, 725, 725], list(taus), [160, 1, 31831])[i // 100 % 6]
                st = (list(steps), None, None, [700, 0, 1], list(steps), None)[i // 100 % 6]
                for d in both:
                    d.set_taus(tt, rate, decim, st)
                if twin is not None:
                    counting(twin)
            if kind == "tampered" and i % 50 == 25:
                for d in both:
                    tamper(d, i)
                if twin is not None:
                    counting(twin)
            if kind == "tampered" and i % 50 == 30 and i // 50 % 7 == 0:
                smp = (1 << 40, -(1 << 31), 5, 1 << 70)    # sums past the words and a small int
            if smp is None:
                for d in both:
                    d.reset()
                continue
            if ref.taus_us is None:
                continue
            x, y, z, t = smp
            good = ref.push(x, y, z, t)
            pushes += 1
            st = state(ref)
            h = checksum(h, good, st)
            if twin is not None:
                if twin.push(x, y, z, t) != good or state(twin) != st:
                    differed += 1
        if s == 0:
            slow0 = slow[0] if native else None
        handed += slow[0]
        total += pushes
        print(json.dumps([s, pushes, ref.saturated & MASK, h]))
    print(json.dumps({"path": D.Delag(1).path, "differed": differed, "slow": slow0, "heap_locked": locked,
                      "handed": handed if native else None, "pushes": total}))


if __name__ == "__main__" and len(sys.argv) > 2:    # a board without argv imports it and calls main()
    main(sys.argv[1], sys.argv[2] or None, len(sys.argv) > 3 and sys.argv[3] == "short")
