"""Simulator benchmarks: `python -m desktop.bench.sim [--repeats R]` prints two tables.

1. Throughput: 10 minutes of two ADS1292 at 4000 SPS with hand motion (2.4 M
   DRDYs, 4.8 M frames), the vectorised path `desktop.sim.scenario.simulate`,
   each run in a fresh process so peak memory (max RSS) is its own. Each
   capture runs R times (default 5, interleaved: 120 s, 600 s, 120 s, ...);
   the table gives the median and the range (min-max) over the runs.
2. Fidelity: the byte-level SPI path (boot, configure by WREG, RDATAC, read
   every frame of both chips on one bus after each DRDY) against the
   vectorised `convert` on the same analog grid, seeds and START tick. The
   codes, headers and violations are deterministic (checked over the runs);
   the byte path's frames/s is the median and range over R runs.
"""

import argparse
import subprocess
import sys
import time

import numpy as np

from desktop.bench.repeat import det, fmt, spread

CHILD = """
import resource, sys, time
from desktop.sim.scenario import Scenario, simulate
c = time.process_time()
t = time.perf_counter()
cap = simulate(Scenario(seconds=float(sys.argv[1]), rate=int(sys.argv[2]), motion="hand"), truth=True)
dt = time.perf_counter() - t
c = time.process_time() - c
print(len(cap["t"]), dt, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, c)
"""


def throughput(seconds, rate):
    out = subprocess.run([sys.executable, "-c", CHILD, str(seconds), str(rate)], check=True,
                         capture_output=True, text=True).stdout.split()
    drdys, dt, rss, cpu = int(out[0]), float(out[1]), float(out[2]), float(out[3])
    return drdys, dt, rss, cpu


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
        ref.append(convert(chip.analog.volts, hw.grid["temp"], A.Config(chip.registers),
                             first_tick=chip.start_tick + A.SETTLE_TICKS[rate_code], n=n,
                             rng=np.random.default_rng(s), step=chip.analog.step, grid_tick0=chip.analog.grid_tick0))
    ref = np.concatenate(ref, axis=1)
    ok_status = int(np.sum(status >> 20 == 0xC))
    return n, int(np.sum(codes != ref)), ok_status, 2 * n, dt, hw.chips[0].violations + hw.chips[1].violations


CAPTURES = ((120, 4000), (600, 4000))
RATE_CODES = (2, 5)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.sim", description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=5, help="runs per configuration (default 5)")
    args = p.parse_args(argv)
    R = max(1, args.repeats)
    from desktop.sim.ads1292.registers import DATA_RATES
    t_start = time.perf_counter()
    notes = []

    runs = {cap: [] for cap in CAPTURES}
    for _ in range(R):                      # interleaved, so a slow spell of the machine hits both
        for cap in CAPTURES:
            runs[cap].append(throughput(*cap))
    print("## Simulation throughput (vectorised path, hand motion, Mag649, two ADS1292)\n")
    print("Median (min-max) over %d runs per capture, each in a fresh process.\n" % R)
    print("| capture | DRDYs | frames (2 chips) | time (s) | frames/s | peak RSS (MB) |")
    print("|---|---|---|---|---|---|")
    for (seconds, rate), rr in runs.items():
        drdys = [r[0] for r in rr]
        d = drdys[0]
        cell = det(drdys, "%d", "DRDYs of the %d s capture" % seconds, notes)
        print("| %d s at %d SPS | %s | %d | %s | %s | %s |"
              % (seconds, rate, cell, 2 * d, fmt([r[1] for r in rr], "%.2f"),
                 fmt([2 * r[0] / r[1] / 1e6 for r in rr], "%.2f", " M"), fmt([r[2] for r in rr], "%.0f")))
    print("\nProcess CPU time of the same runs (s; above 'time' if numpy used more than one core, below it"
          " if the process waited for a core): %s."
          % "; ".join("%d s capture %s" % (cap[0], fmt([r[3] for r in rr], "%.2f")) for cap, rr in runs.items()))

    fid = {code: [] for code in RATE_CODES}
    for _ in range(R):
        for code in RATE_CODES:
            fid[code].append(fidelity(rate_code=code))
    print("\n## Emulator fidelity (byte-level SPI vs vectorised, same grid and seeds)\n")
    print("Codes, headers and violations: the same in each of %d runs (else marked 'varies');"
          " byte path frames/s: median (min-max) over the runs.\n" % R)
    print("| data rate | DRDYs read | codes differing | status headers 1100 | byte path frames/s | violations |")
    print("|---|---|---|---|---|---|")
    for code, rr in fid.items():
        sps = DATA_RATES[code]
        n, frames = rr[0][0], rr[0][3]
        bad = det([r[1] for r in rr], "%d", "codes differing at %d SPS" % sps, notes)
        ok = det([r[2] for r in rr], "%d", "status headers at %d SPS" % sps, notes)
        viol = det([len(r[5]) for r in rr], "%d", "violations at %d SPS" % sps, notes)
        print("| %d SPS | %d | %s of %d | %s of %d | %s | %s |"
              % (sps, n, bad, 4 * n, ok, frames, fmt([r[3] / r[4] for r in rr], "%.0f"), viol))
    for line in notes:
        print("\nNOTE: " + line)
    tp = spread([r[1] for r in runs[CAPTURES[-1]]])
    print("\n(command: python -m desktop.bench.sim --repeats %d; %.0f s wall; 600 s capture median %.2f s,"
          " spread %.0f %% of the median)" % (R, time.perf_counter() - t_start, tp.median,
                                            100 * (tp.hi - tp.lo) / tp.median))


if __name__ == "__main__":
    sys.exit(main())
