"""Simulator benchmarks: `python -m desktop.bench.sim` prints two tables.

1. Throughput: 10 minutes of two ADS1292 at 4000 SPS with hand motion (2.4 M
   DRDYs, 4.8 M frames), the vectorised path `desktop.sim.scenario.simulate`,
   each run in a fresh process so peak memory (max RSS) is its own.
2. Fidelity: the byte-level SPI path (boot, configure by WREG, RDATAC, read
   every frame of both chips on one bus after each DRDY) against the
   vectorised `convert` on the same analog grid, seeds and START tick.
"""

import subprocess
import sys
import time

import numpy as np

CHILD = """
import resource, sys, time
from desktop.sim.scenario import Scenario, simulate
t = time.perf_counter()
cap = simulate(Scenario(seconds=float(sys.argv[1]), rate=int(sys.argv[2]), motion="hand"), truth=True)
dt = time.perf_counter() - t
print(len(cap["t"]), dt, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
"""


def throughput(seconds, rate):
    out = subprocess.run([sys.executable, "-c", CHILD, str(seconds), str(rate)], check=True,
                         capture_output=True, text=True).stdout.split()
    drdys, dt, rss = int(out[0]), float(out[1]), float(out[2])
    return drdys, dt, rss


def fidelity(seconds=2.0, rate_code=5):
    from desktop.sim.ads1292 import registers as A
    from desktop.sim.ads1292.convert import convert
    from desktop.sim.handheld import Handheld
    from desktop.sim.scenario import Scenario
    sc = Scenario(seconds=seconds + 0.2, rate=A.DATA_RATES[rate_code], motion="hand")
    hw = Handheld(sc, t0=0.0)
    bus = hw.bus
    bus.advance(0.05)                                     # tPOR
    regs = sc.registers()
    for i in (0, 1):
        bus.select(i)
        bus.transfer([A.SDATAC])
        bus.transfer([A.WREG | 1, 10] + regs[i][1:12])
        bus.transfer([A.RDATAC])
        bus.select(None)
    bus.start = True
    n = int(seconds * sc.rate)
    raw = np.zeros((n, 2, 9), np.uint8)
    t0 = time.perf_counter()
    for k in range(n):
        bus.wait_drdy(0)
        for i in (0, 1):
            bus.select(i)
            raw[k, i] = np.frombuffer(bus.transfer(bytes(9)), np.uint8)
        bus.select(None)
    dt = time.perf_counter() - t0
    status, codes = A.parse_frames(raw.reshape(-1, 9))
    codes = codes.reshape(n, 4)
    seq = np.random.SeedSequence([sc.seed, sc.motion_seed]).spawn(3)
    ref = []
    for i, s in zip((0, 1), seq[1:]):
        chip = hw.chips[i]
        ref.append(convert(chip._volts, hw.grid["temp"], A.Config(chip.registers),
                             first_tick=chip.start_tick + A.SETTLE_TICKS[rate_code], n=n,
                             rng=np.random.default_rng(s), step=chip._step, grid_tick0=chip._grid_tick0))
    ref = np.concatenate(ref, axis=1)
    ok_status = int(np.sum(status >> 20 == 0xC))
    return n, int(np.sum(codes != ref)), ok_status, 2 * n, dt, hw.chips[0].violations + hw.chips[1].violations


def main():
    print("## Simulation throughput (vectorised path, hand motion, Mag649, two ADS1292)\n")
    print("| capture | DRDYs | frames (2 chips) | time (s) | frames/s | peak RSS (MB) |")
    print("|---|---|---|---|---|---|")
    for seconds, rate in ((120, 4000), (600, 4000)):
        drdys, dt, rss = throughput(seconds, rate)
        print("| %d s at %d SPS | %d | %d | %.2f | %.2f M | %.0f |"
              % (seconds, rate, drdys, 2 * drdys, dt, 2 * drdys / dt / 1e6, rss))
    print("\n## Emulator fidelity (byte-level SPI vs vectorised, same grid and seeds)\n")
    print("| data rate | DRDYs read | codes differing | status headers 1100 | byte path frames/s | violations |")
    print("|---|---|---|---|---|---|")
    for code in (2, 5):
        n, bad, ok, frames, dt, viol = fidelity(rate_code=code)
        from desktop.sim.ads1292.registers import DATA_RATES
        print("| %d SPS | %d | %d of %d | %d of %d | %.0f | %d |"
              % (DATA_RATES[code], n, bad, 4 * n, ok, frames, frames / dt, len(viol)))


if __name__ == "__main__":
    main()
