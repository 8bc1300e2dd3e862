"""The main-loop cost model: what the simulated board charges as chip time (hal_sim.Board.busy).

The host cannot see how long the firmware computes on a microcontroller, so
each piece of main-loop work is charged a fixed simulated time. The values are
fixed parameters, so the tests' stall arithmetic stays fixed; they were first
set from unix-port timings times an assumed 40. Against the instruction counts
of `python -m desktop.bench.cortexm` (docs/firmware.md: 1.5 cycles per Cortex-M3
instruction on a 133 MHz Cortex-M0+) they are conservative but for the final
solve, after which the session ends:

    solve: a provisional or final solve        0.24 s  (counted: 0.20 s provisional, 0.32 s final)
    sample_cal: a decimated sample, calibrating 1.76 ms (counted: 1.3 ms)
    sample: a decimated sample in survey        1.12 ms (counted: 0.8 ms, streaming)
"""

COSTS_S = {"solve": 0.24, "sample_cal": 1.76e-3, "sample": 1.12e-3}


def costs_us(costs):
    """Seconds per unit -> the integer microseconds hal_sim.Board charges."""
    return {k: int(round(v * 1e6)) for k, v in (costs or {}).items()}
