"""The survey output's and the spike screen's cost on the emulated Raspberry Pi Pico: cycles per sample.

    python -m desktop.bench.pico_survey                      # this checkout's device/ and shared/
    python -m desktop.bench.pico_survey --source OTHER_TREE  # another checkout's, to compare

What: micropython-scripts/pico_survey.py runs device/survey.py's Output (stream corrected,
the realistic instrument's calibration, window 2, 10 samples a block, 400 window sums of a
spin) on the rp2 port's firmware in the RP2040 emulator, the modules as .mpy from the Pico's
own mpy-cross: emulated time per decimated sample from the DRDY ring (Acquisition.poll, two
a call, into Output.sample with the firmware's screen and de-lag: the whole per-sample path),
through Output.sample alone (block outputs included; after a collection, then with small live
objects filling the heap to the firmware's free after boot), per |h_c| alone, per block output
alone (to the stand-in line, then through the firmware's Protocol to a port that takes the
bytes), per block's sums alone (Survey.finish); x 125 gives cycles (125 MHz). The
stand-ins (serial line, screen, die) cost a little of their own; the same in both trees.
Then device/screen.py's Screen.push alone on the same spin with a flipped bit in one
sample of 40 (the default spike_nt and scale), the loop's own cost taken off: after a
collection, and with small live objects filling the heap to the firmware's free after boot.
This checkout's native modules for armv6m go on the disk as deploy installs them (where built): a
tree whose shared/fixedpoint.py uses fitsums.magnitude runs |h_c| in C, one whose screen.py uses
screenc.mpy runs the screen's push in C and is timed with its pure-Python push too (the tables
say which).
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

from desktop.devicesim.pico_board import PicoBoard
from desktop.firmware.files import REPO
from desktop.firmware.interpreters import pico_parts
from desktop.firmware.natmod import MODULES, natmod_path
from desktop.methods import fit_array
from desktop.sim.instrument import realistic_instrument

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "micropython-scripts", "pico_survey.py")
STAND_INS = os.path.join(os.path.dirname(SCRIPT), "survey_stand_ins.py")
MHZ = 125
DEVICE = ("survey", "flashlog", "protocol", "screen", "store", "config", "acquisition")   # those a tree has


def _disk(folder, source, job, script=SCRIPT):
    """The modules Output needs, from `source`, as .mpy for the Pico; the scripts (`script` as
    pico_survey.mpy, whatever its name); the job."""
    cross = pico_parts()["mpy_cross"]
    os.makedirs(os.path.join(folder, "shared"))
    pairs = [(os.path.join(source, "shared", n), os.path.join("shared", n))
             for n in sorted(os.listdir(os.path.join(source, "shared"))) if n.endswith(".py")]
    pairs += [(os.path.join(source, "device", n + ".py"), n + ".py") for n in DEVICE
              if os.path.exists(os.path.join(source, "device", n + ".py"))]   # flashlog.py: from 4fef6d7
    pairs += [(script, "pico_survey.py"), (STAND_INS, "survey_stand_ins.py")]
    for src, rel in pairs:
        subprocess.run([cross, "-o", os.path.join(folder, rel[:-3] + ".mpy"), src], check=True)
    with open(os.path.join(folder, "job.json"), "w") as fh:
        json.dump(job, fh)
    for module in MODULES:          # as deploy installs them, where built
        native = natmod_path("armv6m", module)
        if native:
            shutil.copyfile(native, os.path.join(folder, module + ".mpy"))


def run_on_pico(fill, script, lines=False):
    """fill(folder) writes the disk; on a fresh emulated Pico it is copied to /disk and `script`
    imported from it: the JSON of its last line (lines: every line it printed), or None (the
    failure said on stderr)."""
    with tempfile.TemporaryDirectory(prefix="fluxcal-%s-" % script.replace("_", "-")) as tmp:
        disk = os.path.join(tmp, "disk")
        fill(disk)
        with PicoBoard(os.path.join(tmp, "pico.flash")) as board:
            r = subprocess.run([sys.executable, "-m", "mpremote", "connect", board.port, "cp", "-r", disk, ":",
                                "+", "exec", "import sys; sys.path.insert(0, '/disk'); import " + script],
                               capture_output=True, text=True, timeout=1800)
    if r.returncode:
        print("the Pico run failed: %s" % (r.stdout + r.stderr).strip()[-800:], file=sys.stderr)
        return None
    return r.stdout.splitlines() if lines else json.loads(r.stdout.splitlines()[-1])


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.pico_survey", description=__doc__.splitlines()[0])
    p.add_argument("--source", default=REPO, help="the tree whose device/ and shared/ run (default: this one)")
    args = p.parse_args(argv)
    fit_codes, spin, field = realistic_instrument()
    cal = fit_array(fit_codes.astype(float), field=field)
    window = 2
    rng = np.random.default_rng(1)
    sums = (spin[:400] * window + rng.integers(0, window, size=(400, 3))).tolist()
    # the screen's stream: the same spin with a flipped data bit (2**8 .. 2**19 of one code,
    # either sign) in one sample of 40, at random: about 10 spikes, some under spike_nt
    screen_sums = [list(s) for s in sums]
    for i in range(5, 400, 40):
        screen_sums[i][int(rng.integers(0, 3))] += int(rng.choice([-1, 1])) << int(rng.integers(8, 20))
    job = {"cal": cal.to_dict(), "window": window, "per_block": 10, "sums": sums, "screen_sums": screen_sums}
    got = run_on_pico(lambda disk: _disk(disk, os.path.abspath(args.source), job), "pico_survey")
    if got is None:
        return 1
    print("| survey output on the emulated Pico (%s, \\|h_c\\| in %s; %s) | emulated us | cycles |"
          % (got["path"], got.get("magnitude_path", "python"), args.source))
    print("|---|---|---|")
    for key, label in (("ring", "per decimated sample from the ring (Acquisition.poll, 2 a call, into Output.sample; "
                                "the firmware's screen and de-lag; block outputs included)"),
                       ("per_sample", "per decimated sample (Output.sample, block outputs included)"),
                       ("per_sample_full", "the same, small live objects filling the heap to 85 KB free (as after boot)"),
                       ("magnitude", "|h_c| alone"), ("block", "a block's output alone (correct, format the event)"),
                       ("block_protocol", "the same through the firmware's Protocol to the serial port"),
                       ("finish", "a block's sums alone (Survey.finish, from the C's words)")):
        if got.get(key) is not None:
            print("| %s | %.1f | %s |" % (label, got[key], "{:,}".format(round(got[key] * MHZ))))
    print()
    py = "py_screen" in got
    print("| spike screen on the emulated Pico (Screen.push, %s; %d of the 400 flipped-bit samples spikes; %s) "
          "| emulated us | cycles |%s" % (got.get("screen_path", "python"), got["screen_spikes"], args.source,
                                        " the Python push: emulated us, cycles |" if py else ""))
    print("|---|---|---|%s" % ("---|" if py else ""))
    for key, label in (("screen_clean", "a push, the spin, the heap emptied by a collection"),
                       ("screen", "a push, the spin with a flipped bit in 1 sample of 40, the heap emptied"),
                       ("screen_full", "the same, small live objects filling the heap to 85 KB free (as after boot)")):
        more = " %.1f, %s |" % (got["py_" + key], "{:,}".format(round(got["py_" + key] * MHZ))) if py else ""
        print("| %s | %.1f | %s |%s" % (label, got[key], "{:,}".format(round(got[key] * MHZ)), more))
    return 0


if __name__ == "__main__":
    sys.exit(main())
