# Runs under CPython and each MicroPython/CircuitPython build, from argv (the repository root):
# device/screen.py's Screen against the screen as first written (ReferenceScreen below: every
# sample's bend and allowance computed, a call per axis), on the same streams: a turning
# field with noise, one-sample spikes of every size, steps, reversals, clipped and
# full-scale codes (+-2**23), and a fixed 32-bit LCG's random codes (not `random`, whose
# generator differs between runtimes). Prints one JSON line: whether every verdict, every
# accepted sample and every counter matched on this interpreter, and how many samples ran.
import json
import math
import sys

TOP = 1 << 23


class ReferenceScreen:
    """The spike screen as first written: the reference the faster one must equal bit for bit."""

    def __init__(self, scale, window, spike_nt):
        self.k = (scale[0] / window, scale[1] / window, scale[2] / window)
        self.clip = 8323072 * window
        self.spike_nt = spike_nt
        self.spikes = 0
        self.clipped = 0
        self.clip_axis = None
        self.reset()

    def reset(self):
        self._n = 0
        self._typ = 0.0
        self._pending = -1.0

    def push(self, x, y, z, t):
        c = self.clip
        if x >= c or x <= -c or y >= c or y <= -c or z >= c or z <= -c:
            self.clipped += 1
            self.clip_axis = 0 if (x >= c or x <= -c) else (1 if (y >= c or y <= -c) else 2)
            self.reset()
            return False
        n = self._n
        good = False
        if n == 2:
            k = self.k
            cx, cy, cz = self._cx, self._cy, self._cz
            d = max(_bend(cx - self._px, cx - x, k[0]), _bend(cy - self._py, cy - y, k[1]),
                    _bend(cz - self._pz, cz - z, k[2]))
            v = [(x - self._px) * k[0], (y - self._py) * k[1], (z - self._pz) * k[2]]
            h = [cx * k[0], cy * k[1], cz * k[2]]
            h2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2]
            bend = 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) / (h2 ** 0.5) if h2 > 0 else 0.0
            allow = 4.0 * self._typ
            if bend > allow:
                allow = bend
            if d > self.spike_nt + allow:
                self.spikes += 1
                self._pending = -1.0
                self._cx, self._cy, self._cz, self._ct = x, y, z, t
                return False
            e = max(abs(cx + cx - self._px - x) * k[0], abs(cy + cy - self._py - y) * k[1],
                    abs(cz + cz - self._pz - z) * k[2])
            if self._pending >= 0.0:
                self._typ += (self._pending - self._typ) * 0.0625
            self._pending = 0.5 * e
            good = True
            self.x, self.y, self.z, self.t = cx, cy, cz, self._ct
        if n >= 1:
            self._px, self._py, self._pz = self._cx, self._cy, self._cz
        self._cx, self._cy, self._cz, self._ct = x, y, z, t
        self._n = n + 1 if n < 2 else 2
        return good


def _bend(a, b, k):
    if a > 0 and b > 0:
        return (a if a < b else b) * k
    if a < 0 and b < 0:
        return -(a if a > b else b) * k
    return 0.0


class Lcg:
    def __init__(self, seed):
        self.s = seed

    def next(self, bits):
        self.s = (1103515245 * self.s + 12345) & 0xFFFFFFFF
        return self.s >> (32 - bits)


def streams(window):
    """(x, y, z, t) boxcar sums of `window` codes each, and a None where the stream has a gap."""
    r = Lcg(7)
    full = TOP * window
    amp = 3300000 * window      # ~48 uT at the default scale
    for turn_dps in (30.0, 360.0, 1500.0):
        w = turn_dps * math.pi / 180.0 / 100.0     # rad per sample at 100 samples/s
        for i in range(800):
            a = i * w
            noise = r.next(6) - 32
            x = int(amp * math.cos(a)) + noise
            y = int(amp * math.sin(a) * 0.9) - noise
            z = int(amp * 0.3) + (r.next(4) - 8)
            if i % 37 == 5:                   # a flipped bit 2**k in one frame of the boxcar
                bit = 1 << (8 + r.next(4))
                x += bit if r.next(1) else -bit
            if i % 53 == 11:                  # a step that stays
                z += 40000
            if i % 97 == 50:                  # a reversal of the hand
                w = -w
            yield x, y, z, i
        yield None
    for i in range(3000):                     # random codes anywhere in the range, clipped ones included
        yield ((r.next(24) - TOP) * window, (r.next(24) - TOP) * window, (r.next(24) - TOP) * window, i)
    edges = (-full, full - 1, -full + 1, 0, 1, -1, full >> 1, 8323072 * window, 8323072 * window - 1)
    for x in edges:
        for y in edges:
            for z in edges:
                yield x, y, z, 0
    for i in range(300):                      # a still field: the typical bend learnt at noise level
        yield 1000000 + r.next(3), -2000000 + r.next(3), 500000, i


def main(root):
    sys.path.insert(0, root + "/device")
    from screen import Screen
    same = True
    n = 0
    for scale, window, spike_nt in (((0.0144243258, 0.0144243258, 0.0144243258), 2, 5.0),
                                    ((0.011, 0.0173, 0.0144), 1, 0.5), ((1e-6, 1e3, 2.5), 64, 50.0)):
        new = Screen(scale, window, spike_nt)
        ref = ReferenceScreen(scale, window, spike_nt)
        for s in streams(window):
            if s is None:
                new.reset()
                ref.reset()
                continue
            n += 1
            a = new.push(s[0], s[1], s[2], s[3])
            b = ref.push(s[0], s[1], s[2], s[3])
            if a != b or new._typ != ref._typ or (a and (new.x, new.y, new.z, new.t) != (ref.x, ref.y, ref.z, ref.t)):
                same = False
        if (new.spikes, new.clipped, new.clip_axis) != (ref.spikes, ref.clipped, ref.clip_axis):
            same = False
        print(json.dumps({"spikes": ref.spikes, "clipped": ref.clipped}))
    print(json.dumps({"same": same, "samples": n}))


if __name__ == "__main__":
    main(sys.argv[1])
