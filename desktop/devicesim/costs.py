"""The main-loop cost model: what the simulated board charges as chip time (hal_sim.Board.busy).

The host cannot see how long the firmware computes on a microcontroller, so
each piece of main-loop work is charged a fixed simulated time: the unix-port
costs measured by `python -m desktop.bench.device` (docs/firmware.md) times
the RP2040 scaling assumption stated there.

    solve: a provisional or final solve, ~6 ms on the unix port
    sample_cal: one decimated sample while calibrating: (7377 us/s - 1963 us/s in the
        DRDY handler - 1000 us/s of solves, 5 ms every 5 s) / 100 samples/s = 44 us
    sample: one sample in survey with stream and log on: (4717 - 1963) / 100 = 28 us
"""

RP2040_SCALE = 40
UNIX_COSTS_S = {"solve": 6e-3, "sample_cal": 44e-6, "sample": 28e-6}
COSTS_S = {k: v * RP2040_SCALE for k, v in UNIX_COSTS_S.items()}


def costs_us(costs):
    """Seconds per unit -> the integer microseconds hal_sim.Board charges."""
    return {k: int(round(v * 1e6)) for k, v in (costs or {}).items()}
