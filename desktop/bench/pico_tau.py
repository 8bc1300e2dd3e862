"""What the firmware's tau estimate costs on the emulated Raspberry Pi Pico (125 MHz, native sums).

    python -m desktop.bench.pico_tau        # about 2 wall min

micropython-scripts/tau_core.py on the rp2 port's firmware in the RP2040 emulator, as
desktop.bench.pico_core runs its script: per accepted sample the four TauSums adds, the search over tau at the finish (device/lagfit.py's one-step solves) and the
final solve, on 1,300 samples. Emulated time (the clock advances per instruction cycle).
"""

import sys

from desktop.bench.pico_core import SCRIPT, run
from desktop.firmware.natmod import natmod_path

TAU_SCRIPT = SCRIPT.replace("cortexm_core.py", "tau_core.py")


def main(argv=None):
    native = natmod_path("armv6m")
    if native is None:
        print("no fitsums.mpy for armv6m: make interpreters", file=sys.stderr)
        return 1
    path, f = run(native, TAU_SCRIPT)
    ms = 1e-6
    print("sums: %s, %d samples" % (path, f["n"]))
    print("TauSums.add (four nodes): %.3f ms a sample (one EllipsoidFit.add: python -m desktop.bench.pico_core)"
          % (f["tausums_add_ns"] * ms))
    print("search over tau: %.0f ms, %d one-step solves (t = %.3f steps; the data's -1.6)" % (
        f["search_ns"] * ms, f["solves"], f["t"]))
    print("final solve at that tau: %.0f ms; at the configured tau: %.0f ms" % (f["final_solve_ns"] * ms,
                                                                                f["configured_solve_ns"] * ms))
    return 0


if __name__ == "__main__":
    sys.exit(main())
