# Runs under each MicroPython/CircuitPython build, from argv (the repository root, the streams
# file of tests/test_device_screen.py, which cfg to run: 1 is the first): device/screen.py's
# Screen.push on that cfg's samples with the heap locked (micropython.heap_lock), the first 20
# unlocked (its attributes made). A push that needs the heap (the exact bend's big integers,
# a few a second) raises MemoryError before it changes the screen; it is counted and pushed
# again unlocked. Prints one JSON line: pushes, the ones that allocated, spikes.
import json
import sys

import micropython


def main(root, path, which):
    sys.path.insert(0, root + "/device")
    sys.path.insert(0, root)
    from screen import Screen
    samples = []
    cfg = None
    n = 0
    with open(path) as fh:
        for line in fh:
            w = line.split()
            if w[0] == "cfg":
                n += 1
                if n == which:
                    cfg = ((float(w[1]), float(w[2]), float(w[3])), int(w[4]), float(w[5]))
                elif n > which:
                    break
            elif n == which:
                samples.append(None if w[0] == "gap" else (int(w[0]), int(w[1]), int(w[2]), int(w[3])))
    sc = Screen(cfg[0], cfg[1], cfg[2])
    allocated = 0
    for i in range(len(samples)):
        s = samples[i]
        if i < 20 or s is None:
            if s is None:
                sc.reset()
            else:
                sc.push(s[0], s[1], s[2], s[3])
            continue
        micropython.heap_lock()
        try:
            sc.push(s[0], s[1], s[2], s[3])
            micropython.heap_unlock()
        except MemoryError:
            micropython.heap_unlock()
            allocated += 1
            sc.push(s[0], s[1], s[2], s[3])
    print(json.dumps({"pushes": len(samples) - 20, "allocated": allocated, "spikes": sc.spikes}))


main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
