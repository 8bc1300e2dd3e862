# Runs under `micropython -X heapsize=...` (data for desktop/bench/core.py): fills an EllipsoidFit with 1000
# distorted-sphere samples (generated on the fly, no stored test data) and
# solves it. desktop/bench/core.py bisects the heap size this needs.
import gc, sys, math
sys.path.insert(0, sys.argv[1])
from shared.fit import EllipsoidFit
seed = 1
def rnd():
    global seed
    seed = (seed * 1103515245 + 12345) & 0x7FFFFFFF
    return seed / 2147483648.0
fit = EllipsoidFit()
for _ in range(1000):
    c = 2 * rnd() - 1; p = 2 * math.pi * rnd(); s = math.sqrt(1 - c * c)
    x, y, z = 5e6 * s * math.cos(p), 5e6 * s * math.sin(p), 5e6 * c
    fit.add(int(1.004 * x + 0.01 * y + 30000), int(0.997 * y + 20000), int(1.001 * z - 0.015 * x - 10000))
gc.collect()
base = gc.mem_alloc()
cal = fit.solve(scale=0.01)
print("ok", base)
