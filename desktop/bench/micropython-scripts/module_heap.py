# MicroPython script, run by desktop/bench/heap.py --modules as `micropython -m module_heap NAME...` with
# the firmware's .mpy image on MICROPYPATH: the heap each module's import adds (gc.mem_alloc() after
# gc.collect(), before and after), in the order given, so each figure holds what that module imports
# and no module before it did. The interned names (the qstr pool, which grows in doubling chunks and
# is never freed) fall on the import that needed the next chunk.
import gc
import sys


def heap():
    gc.collect()
    return gc.mem_alloc()


added = []
prev = heap()
for name in sys.argv[1:]:
    __import__(name)
    now = heap()
    added.append(now - prev)
    prev = now
print(" ".join(str(a) for a in added))
