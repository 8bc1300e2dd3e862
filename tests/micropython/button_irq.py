# Runs on the emulated Pico (tests/test_device_interrupts.py): hal_micropython's Board as the
# firmware builds it (the button's pin interrupt attached), its handler called as a hard IRQ runs
# it, with the heap locked (an allocation raises MemoryError), then button_edge taking the closing
# once and not again. main(root, natmod): root holds device/ and shared/ as .mpy. Prints one JSON line.
import json
import sys


def main(root, natmod=None):
    for folder in (root + "/device", root):
        if folder not in sys.path:
            sys.path.insert(0, folder)
    import micropython
    import time

    import config
    import hal_micropython

    b = hal_micropython.Board(config.defaults())
    out = {"edges": b.button_edges, "errors": []}
    t0 = time.ticks_ms()
    err = None
    micropython.heap_lock()
    try:
        b._button_closed(None)
    except MemoryError as e:     # (named only: its repr would allocate under the lock)
        err = e
    micropython.heap_unlock()
    if err is not None:
        out["errors"].append(repr(err))
    now = time.ticks_add(t0, 50)
    first = b.button_edge(now)
    out["taken"] = time.ticks_diff(first, t0)          # 0 or a ms or two: the closing's tick
    out["again"] = time.ticks_diff(b.button_edge(now), now)   # taken once: the poll's own time after
    print(json.dumps(out))
