"""Benchmarks: scripts that print the README's and docs' tables. Not tests.

    python -m desktop.bench           # the calibration core (core.py): accuracy, MicroPython cost
    python -m desktop.bench.device    # the firmware: cost, heap, accuracy sweep, load, power
    python -m desktop.bench.sim       # the simulator: throughput, byte-level fidelity
    python -m desktop.bench.commands  # wall time of `make demo` and a 10-minute `fluxcal simulate`
    python -m desktop.bench.surveyday # temperature compensation over a simulated survey day

micropython-scripts/ holds what they run inside the `micropython` executable:
data files for these benchmarks (the folder name is not a Python identifier,
so nothing imports them as desktop modules).
"""
