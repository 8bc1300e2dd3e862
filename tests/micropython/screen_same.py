# Runs under CPython and each MicroPython/CircuitPython build, from argv (the repository root,
# a file of streams written by tests/test_device_screen.py): device/screen.py's integer Screen
# on every stream, and the float screen it replaced (FloatScreen below: the screen as first
# written, every sample's bend computed) beside it. The file's lines: "cfg sx sy sz window
# spike_nt" starts a screen pair, "gap" resets both, "x y z t" is a sample (integers).
# Prints one JSON line per cfg (the integer screen's counts and a digest of its verdicts and
# learnt allowance, which must be the same on every interpreter) and a last one: how often
# the two screens disagreed, and how many of those were within the integer screen's stated
# resolution of the float one's threshold (borderline; after each disagreement both reset,
# so the next judgement starts from the same state).
import json
import sys

MASK = 0x3FFFFFFF


class FloatScreen:
    """The float spike screen (device/screen.py before the integers): the reference."""

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
        self.margin = None      # the last judgement: d - threshold (nT), and the bound on it
        self.bound = None

    def push(self, x, y, z, t):
        self.margin = None
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
            d = max(_out(cx - self._px, cx - x, k[0]), _out(cy - self._py, cy - y, k[1]),
                    _out(cz - self._pz, cz - z, k[2]))
            v = [(x - self._px) * k[0], (y - self._py) * k[1], (z - self._pz) * k[2]]
            h = [cx * k[0], cy * k[1], cz * k[2]]
            h2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2]
            bend = 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) / (h2 ** 0.5) if h2 > 0 else 0.0
            allow = 4.0 * self._typ
            # device/screen.py's resolution: each quantity within 2**-11 of itself + 2**-8 nT
            self.margin = d - self.spike_nt - max(allow, bend)
            self.bound = (d + self.spike_nt + allow + bend) / 2048.0 + 1 / 256.0
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


def _out(a, b, k):
    if a > 0 and b > 0:
        return (a if a < b else b) * k
    if a < 0 and b < 0:
        return -(a if a > b else b) * k
    return 0.0


def main(root, path):
    sys.path.insert(0, root + "/device")
    sys.path.insert(0, root)
    from screen import Screen
    run = {"samples": 0, "judged": 0, "near": 0, "disagree": 0, "borderline": 0, "worst": 0.0, "accepted_differ": 0}
    new = ref = alone = None
    digest = 0

    def close():
        if alone is not None:
            print(json.dumps({"spikes": alone.spikes, "clipped": alone.clipped, "digest": digest,
                              "float_spikes": ref.spikes}))

    with open(path) as fh:
        for line in fh:
            w = line.split()
            if w[0] == "cfg":
                close()
                scale = (float(w[1]), float(w[2]), float(w[3]))
                window = int(w[4])
                spike_nt = float(w[5])
                new = Screen(scale, window, spike_nt)      # beside the float one, reset with it
                ref = FloatScreen(scale, window, spike_nt)
                alone = Screen(scale, window, spike_nt)    # on its own: the digest
                digest = 0
                continue
            if w[0] == "gap":
                new.reset()
                ref.reset()
                alone.reset()
                continue
            x, y, z, t = int(w[0]), int(w[1]), int(w[2]), int(w[3])
            run["samples"] += 1
            g = alone.push(x, y, z, t)
            digest = (digest * 31 + (2 if g else 1) + 4 * (alone.allowance() & 0xFFFFF)) & MASK
            if g:
                digest = (digest * 31 + ((alone.x ^ alone.y ^ alone.z ^ alone.t) & 0xFFFFF)) & MASK
            a = new.push(x, y, z, t)
            b = ref.push(x, y, z, t)
            if ref.margin is not None:
                run["judged"] += 1
                if abs(ref.margin) <= ref.bound:
                    run["near"] += 1
            if a != b:
                run["disagree"] += 1
                r = abs(ref.margin) / ref.bound
                if r <= 1.0:
                    run["borderline"] += 1
                if r > run["worst"]:
                    run["worst"] = r
                new.reset()
                ref.reset()
            elif a and (new.x, new.y, new.z, new.t) != (ref.x, ref.y, ref.z, ref.t):
                run["accepted_differ"] += 1
    close()
    print(json.dumps(run))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
