# Runs on the emulated Pico (tests/test_device_interrupts.py): hal_micropython's Board as the
# firmware builds it (the button's pin interrupt attached), its handler called as a hard IRQ runs
# it, with the heap locked (an allocation raises MemoryError), then button_edge taking the closing
# once and not again; then a whole press (its edges as the handler sees them), which button_press
# takes once from its first closing, and a closing under the debounce, which it does not. main(root, natmod): root holds device/ and shared/ as .mpy. Prints one JSON line.
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
    # the contact's level as the handler reads it (rp2040js drives an input pin from its runner
    # alone: an output's level, or a pull-up, is not seen at the pad), closed
    level = [0]

    def contact(v=None):
        if v is None:
            return level[0]
        level[0] = v

    b._button = contact
    t0 = time.ticks_ms()
    err = None
    micropython.heap_lock()
    try:
        b._button_moved(None)
    except MemoryError as e:     # (named only: its repr would allocate under the lock)
        err = e
    micropython.heap_unlock()
    if err is not None:
        out["errors"].append(repr(err))
    now = time.ticks_add(t0, 50)
    first = b.button_edge(now)
    out["taken"] = time.ticks_diff(first, t0)          # 0 or a ms or two: the closing's tick
    out["again"] = time.ticks_diff(b.button_edge(now), now)   # taken once: the poll's own time after
    # a whole press between two polls, its edges as the interrupt sees them: closed, a bounce
    # open and closed again, held 60 ms, open
    t0 = time.ticks_ms()
    for v, ms in ((0, 2), (1, 1), (0, 60), (1, 5)):
        contact(v)
        b._button_moved(None)
        time.sleep_ms(ms)
    now = time.ticks_ms()
    press = b.button_press(now, 30)
    out["press"] = None if press is None else time.ticks_diff(press, t0)   # 0 or a ms: the first closing
    out["press_again"] = b.button_press(now, 30)       # taken once
    for v, ms in ((0, 10), (1, 5)):                     # and a 10 ms closing is no press
        contact(v)
        b._button_moved(None)
        time.sleep_ms(ms)
    out["short"] = b.button_press(time.ticks_ms(), 30)
    print(json.dumps(out))
