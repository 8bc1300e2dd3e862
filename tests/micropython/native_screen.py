# Runs under CPython (the pure-Python push alone: the reference) and each MicroPython/CircuitPython board
# (with the native push where screenc.mpy loads), from argv or main(root, natmod_folder):
# puts the folder holding screenc.mpy and the repository (device/, shared/) on sys.path and
# pushes the same samples through two of device/screen.py's screens, Screen(..., native=False)
# (the reference) and Screen (native where the module loads). After every push the verdict, the counters (spikes,
# clipped, clip_axis), the outputs (x, y, z, t) and the whole state (_st) must be the same.
# Samples come from a fixed 32-bit LCG (lcg.py beside it): a turning field with noise and reversals,
# flipped bits 2**0 .. 2**22 of a code in one sample (spikes either side of spike_nt), steps
# that stay, gaps (reset), clipped samples, random codes over the whole range, the +-2**23
# extremes in every combination, a still field, and the learnt threshold set by hand past the
# native words' bounds; scales, windows and spike_nt across what the config allows (1e-6 ..
# 1e3 nT a code, window 1 .. 64, spike_nt 1 .. 1e5 nT). Prints one line per scenario (the
# reference's counts and a checksum of every verdict and state: compared with CPython's), then
# one JSON line: the screen's path, the pushes where the two differed, the pushes the native
# push handed to Python in scenario 0 (a smooth stream: only the two after the reset), and
# what a smooth stream pushed with the heap locked raised.
import gc
import json
import sys

TOP = 1 << 23
MASK = 0x3FFFFFFF
# (scale per axis, window, spike_nt, stream, samples)
SCENARIOS = (((0.0144243258, 0.0144243258, 0.0144243258), 2, 30.0, "smooth", 600),
             ((0.0144243258, 0.0144243258, 0.0144243258), 2, 30.0, "hand", 1500),
             ((0.011, 0.0173, 0.0144), 1, 1.0, "hand", 800),
             ((0.0144243258, 0.0144243258, 0.0144243258), 64, 5.0, "hand", 600),
             ((1e-6, 1e3, 2.5), 64, 50.0, "hand", 500),
             ((1e3, 1e3, 1e3), 1, 100000.0, "hand", 400),
             ((0.0144243258, 0.0144243258, 0.0144243258), 3, 30.0, "random", 500),
             ((0.0144243258, 0.0144243258, 0.0144243258), 1, 30.0, "edges", 0),
             ((0.0144243258, 0.0144243258, 0.0144243258), 2, 30.0, "tampered", 300))


def samples(rng, kind, window, n):
    """(x, y, z, t) window sums, None for a gap."""
    full = TOP * window
    if kind == "edges":
        edges = (-full, full - 1, -full + 1, 0, 1, -1, full >> 1, 8323072 * window, 8323072 * window - 1)
        for x in edges:
            for y in edges:
                for z in edges:
                    yield x, y, z, x - y
        return
    # a field turning at a few hundred deg/s: integer velocity and acceleration, noise on top
    # (smooth: slower, never reversing within its samples)
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
                v[a] = -v[a]                    # a reversal
            p[a] += v[a]
        s = [p[0] + rng.signed(5), p[1] + rng.signed(5), p[2] + rng.signed(5), i]
        if kind == "smooth":
            yield tuple(s)
            continue
        r = rng.bits(7)
        if r < 4:                               # a flipped bit 2**k in one code of the boxcar
            b = 1 << rng.bits(5) % 23
            s[rng.bits(2) % 3] += b if rng.bits(1) else -b
        elif r == 4:                            # a step that stays
            p[rng.bits(2) % 3] += rng.signed(18)
        elif r == 5:
            yield None                          # a gap
        elif r == 6:                            # clipped on one axis
            s[rng.bits(2) % 3] = full - 1 - rng.bits(16) if rng.bits(1) else -full + rng.bits(16)
        yield tuple(s)


def state(sc):
    return [sc.spikes, sc.clipped, sc.clip_axis, sc.x, sc.y, sc.z, sc.t] + list(sc._st)


def checksum(h, good, st):
    h = (h * 31 + (2 if good else 1)) & MASK
    for v in st:
        h = (h * 31 + (-7 if v is None else v & 0xFFFFFFF)) & MASK
    return h


def heap_locked(S, Rand):
    """A smooth stream through the native screen with the heap locked: what it raised."""
    import micropython
    rng = Rand(5)
    sc = S.Screen((0.0144243258, 0.0144243258, 0.0144243258), 2, 30.0)
    ref = S.Screen((0.0144243258, 0.0144243258, 0.0144243258), 2, 30.0, native=False)
    pushes = [None] * 120       # (the Cortex-M3 board's heap is small)
    good = [0] * len(pushes)
    for i, s in enumerate(samples(rng, "smooth", 2, len(pushes))):
        pushes[i] = s
        good[i] = ref.push(s[0], s[1], s[2], s[3])
    same = 0
    errors = []
    push = sc.push
    micropython.heap_lock()
    try:
        for i in range(len(pushes)):        # (enumerate would allocate its tuples)
            s = pushes[i]
            if push(s[0], s[1], s[2], s[3]) == good[i]:
                same += 1
    except MemoryError:
        errors.append("MemoryError")
    finally:
        micropython.heap_unlock()
    return errors, same == len(pushes)


def sizes(short):
    """SCENARIOS' sample counts; short (the emulated boards, at a few MHz of emulation): a quarter
    of each stream's, all of the tampered's six thresholds."""
    return [sc[4] if not short or sc[3] == "tampered" else sc[4] // 4 for sc in SCENARIOS]


def main(root, natmod=None, short=None):
    if short is None:
        short = sys.platform not in ("linux", "darwin", "win32")    # a board: rp2, qemu
    for folder in (root, root + "/device", root + "/tests/micropython", natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    import screen as S
    from lcg import Rand

    native = S._NativePush is not None
    slow = [0]

    def counting(sc):
        """The native screen, counting the pushes it hands to Python."""
        def python_push(self, x, y, z, t):
            slow[0] += 1
            return S.Screen.push(self, x, y, z, t)
        sc.push = S._NativePush(sc, python_push)
        return sc

    # first, on a fresh heap (the rp2 port, after the scenarios, can fail to find 1-2 KB for
    # a list with 200 KB free, the pure-Python screen alike)
    locked = heap_locked(S, Rand) if native else None
    gc.collect()
    rng = Rand(19)
    differed = 0
    slow0 = None
    for s, (scale, window, spike_nt, kind, _) in enumerate(SCENARIOS):
        n = sizes(short)[s]
        gc.collect()
        ref = S.Screen(scale, window, spike_nt, native=False)
        twin = counting(S.Screen(scale, window, spike_nt)) if native else None
        slow[0] = 0
        h = 0
        pushes = 0
        for i, smp in enumerate(samples(rng, kind, window, n)):
            if kind == "tampered" and i % 50 == 25:
                # the learnt threshold past what a 32-bit port's small int holds, and past the
                # native words' bound on a 64-bit one: the push must go to Python there
                thr = ((1 << 29) - 1, 1 << 30, (1 << 30) + 5, 1 << 45, 1 << 61, 1 << 70)[i // 50]
                ref._st[8] = thr
                if twin is not None:
                    twin._st[8] = thr
            if smp is None:
                ref.reset()
                if twin is not None:
                    twin.reset()
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
        print(json.dumps([s, pushes, ref.spikes, ref.clipped, ref.clip_axis, ref.allowance() & MASK, h]))
    path = S.Screen((1.0, 1.0, 1.0), 1, 1.0).path
    print(json.dumps({"path": path, "differed": differed, "slow": slow0, "heap_locked": locked}))


if __name__ == "__main__" and len(sys.argv) > 2:    # a board without argv imports it and calls main()
    main(sys.argv[1], sys.argv[2] or None, len(sys.argv) > 3 and sys.argv[3] == "short")
