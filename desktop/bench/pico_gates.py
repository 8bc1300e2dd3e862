"""The calibration gates' cost on the emulated Raspberry Pi Pico: cycles per decimated sample.

    python -m desktop.bench.pico_gates                      # this checkout's device/ and shared/
    python -m desktop.bench.pico_gates --source OTHER_TREE  # another checkout's, to compare

What: micropython-scripts/pico_gates.py runs device/gates.py's Gates.sample on 800 samples of a
slow spiral over the sphere at the config's defaults, on the rp2 port's firmware in the RP2040
emulator (the modules as .mpy from the Pico's own mpy-cross, the native modules for armv6m as
deploy installs them: Gates.sample in C where gatesc.mpy is built), once without a provisional
calibration and once judged against one (the disturbance gate's exact |h_c|): emulated time per
call, add() and the residual batches of the samples taken included; x 125 gives cycles (125 MHz).
"""

import argparse
import os
import shutil
import subprocess
import sys

from desktop.bench.pico_survey import run_on_pico
from desktop.firmware.files import REPO
from desktop.firmware.interpreters import pico_parts
from desktop.firmware.natmod import MODULES, natmod_path

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts", "pico_gates.py")
MHZ = 125
DEVICE = ("gates", "residuals", "config")


def _disk(folder, source):
    """shared/ and the gates' modules from `source`, and the script, as .mpy; the native modules."""
    cross = pico_parts()["mpy_cross"]
    os.makedirs(os.path.join(folder, "shared"))
    pairs = [(os.path.join(source, "shared", n), os.path.join("shared", n))
             for n in sorted(os.listdir(os.path.join(source, "shared"))) if n.endswith(".py")]
    pairs += [(os.path.join(source, "device", n + ".py"), n + ".py") for n in DEVICE] + [(SCRIPT, "pico_gates.py")]
    for src, rel in pairs:
        subprocess.run([cross, "-o", os.path.join(folder, rel[:-3] + ".mpy"), src], check=True)
    for module in MODULES:          # as deploy installs them, where built
        native = natmod_path("armv6m", module)
        if native:
            shutil.copyfile(native, os.path.join(folder, module + ".mpy"))


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.pico_gates", description=__doc__.splitlines()[0])
    p.add_argument("--source", default=REPO, help="the tree whose device/ and shared/ run (default: this one)")
    args = p.parse_args(argv)
    source = os.path.abspath(args.source)
    got = run_on_pico(lambda disk: _disk(disk, source), "pico_gates")
    if got is None:
        return 1
    print("| calibration gates on the emulated Pico (Gates.sample %s; |h_c| %s; %s) | emulated us | cycles |"
          % (got.get("gates", "python"), got["magnitude"], source))
    print("|---|---|---|")
    for key, label in (("first", "a sample, no provisional calibration (%d of 800 taken)" % got["taken"]),
                       ("provisional", "a sample, the disturbance gate on (%d of 800 taken)" % got["taken_provisional"])):
        print("| %s | %.1f | %s |" % (label, got[key], "{:,}".format(round(got[key] * MHZ))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
