"""The de-lag's push (shared/delag.py Delag.push) on the emulated Pico, in C and in Python.

    python -m desktop.bench.pico_delag

400 decimated samples of the realistic instrument's spin (window 2), pushed through a Delag at
the firmware's defaults (tau 31,839 us: the Mag648's whole response, 1000 SPS, decim 10),
without tau steps (the survey) and with them (a calibration estimating tau), each by the push
the firmware gets (in C where this checkout's armv6m delagc.mpy is built: it goes on the disk
as deploy installs it) and by the pure-Python push (native=False, CircuitPython's path); the
loop's own cost taken off. Emulated us at 125 MHz, and cycles.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys

import numpy as np

from desktop.firmware.files import REPO
from desktop.firmware.interpreters import pico_parts
from desktop.firmware.natmod import natmod_path
from desktop.bench.pico_survey import run_on_pico
from desktop.sim.instrument import realistic_instrument

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts", "pico_delag.py")
MHZ = 125


def _disk(disk, sums):
    """shared/delag.py and the script as .mpy for the Pico, the job, delagc.mpy where built."""
    cross = pico_parts()["mpy_cross"]
    os.makedirs(os.path.join(disk, "shared"))
    for src, rel in ((os.path.join(REPO, "shared", "__init__.py"), "shared/__init__.py"),
                     (os.path.join(REPO, "shared", "delag.py"), "shared/delag.py"), (SCRIPT, "pico_delag.py")):
        subprocess.run([cross, "-o", os.path.join(disk, rel[:-3] + ".mpy"), src], check=True)
    with open(os.path.join(disk, "job.json"), "w") as fh:
        json.dump({"sums": sums}, fh)
    native = natmod_path("armv6m", "delagc")
    if native:
        shutil.copyfile(native, os.path.join(disk, "delagc.mpy"))


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.pico_delag", description=__doc__.splitlines()[0])
    p.parse_args(argv)
    _, spin, _ = realistic_instrument()
    window = 2
    sums = (spin[:400] * window + np.random.default_rng(1).integers(0, window, size=(400, 3))).tolist()
    got = run_on_pico(lambda disk: _disk(disk, sums), "pico_delag")
    if got is None:
        return 1
    print("| de-lag on the emulated Pico (Delag.push, %s; 400 samples of the spin, tau 31,839 us) "
          "| emulated us, cycles | the Python push: emulated us, cycles |" % got["path"])
    print("|---|---|---|")
    for key, label in (("plain", "a push, no tau steps (the survey)"),
                       ("steps", "a push with tau steps (a calibration estimating tau)")):
        a, b = got[key + "_native"], got[key + "_python"]
        print("| %s | %.1f, %s | %.1f, %s |" % (label, a, "{:,}".format(round(a * MHZ)),
                                               b, "{:,}".format(round(b * MHZ))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
