# Runs under a MicroPython build (tests/test_device_heap.py), from a folder holding loopboard.py
# (desktop/bench/micropython-scripts) and the frame file, the firmware's .mpy image on MICROPYPATH.
# argv: frames root scale name... Boots the App on the loop-back board, then imports each named
# module (the firmware's imports after boot), printing micropython.qstr_info() after "boot:" and
# after "later:"; and "resident:" with the named modules still imported after boot.
import sys

import micropython
from loopboard import LoopBoard


def main():
    frames, root, scale, names = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4:]
    import app as appmod
    import store
    store.save(root, "config", {"rate": 1000, "decim": 10, "window": 2, "scale_x": scale, "scale_y": scale,
                                "scale_z": scale, "auto_finish": False})
    appmod.App(LoopBoard(open(frames, "rb"), root, 1000))
    resident = [name for name in names if name in sys.modules]
    print("boot:")
    micropython.qstr_info()
    for name in names:
        if name != "shared.linalg_native" or "linalgc" in sys.modules:   # as calibration_flow.py's start
            __import__(name)
    print("later:")
    micropython.qstr_info()
    print("resident:", " ".join(resident))


main()
