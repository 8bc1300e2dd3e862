"""fluxcal correct CAL.json RAW -o OUT.csv"""

import json

from desktop.errors import CommandError
from desktop.fitting import correct_array
from desktop.rawio import read_raw, write_corrected
from shared.calibration import Calibration

HELP = "apply a calibration: write x,y,z,magnitude in nT"


def add_arguments(p):
    p.add_argument("calibration", help="calibration JSON written by `fluxcal fit`")
    p.add_argument("raw", help="CSV with a header containing x,y,z (nT), or a simulator .npz")
    p.add_argument("-o", "--output", required=True, help="CSV to write (x,y,z,magnitude)")


def load_calibration(path):
    try:
        with open(path) as fh:
            d = json.load(fh)
    except OSError as exc:
        raise CommandError("%s: %s" % (path, exc.strerror or exc))
    except ValueError as exc:
        raise CommandError("%s: not JSON (%s)" % (path, exc))
    try:
        return Calibration.from_dict(d)
    except ValueError as exc:
        raise CommandError("%s: invalid calibration: %s" % (path, exc))


def run(args):
    cal = load_calibration(args.calibration)
    h = read_raw(args.raw)
    corrected = correct_array(cal, h)
    write_corrected(args.output, corrected)
    mag = (corrected ** 2).sum(axis=1) ** 0.5
    print("%d rows: |B| mean %.3f nT, peak-to-peak %.3f nT" % (len(mag), mag.mean(), mag.max() - mag.min()))
    return 0
