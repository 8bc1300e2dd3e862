"""fluxcal correct CAL.json RAW -o OUT.csv [--columns X,Y,Z --unit U --scale K --skip N]"""

from desktop.cli._log_options import add_log_arguments, log_format

HELP = "apply a calibration: write x,y,z,magnitude in nT"


def add_arguments(p):
    p.add_argument("calibration", help="calibration JSON written by `fluxcal fit`")
    p.add_argument("raw", help="magnetometer log (CSV or whitespace-separated; see --columns, --unit) or a capture .npz")
    p.add_argument("-o", "--output", required=True, help="CSV to write (x,y,z,magnitude)")
    add_log_arguments(p)


def run(args):
    from desktop.formats.calibration import load_calibration
    from desktop.formats.readings import read_raw, write_corrected
    from desktop.methods import correct_array

    cal = load_calibration(args.calibration)
    h = read_raw(args.raw, log_format(args))
    corrected = correct_array(cal, h)
    write_corrected(args.output, corrected)
    mag = (corrected ** 2).sum(axis=1) ** 0.5
    print("%d rows: |B| mean %.3f nT, peak-to-peak %.3f nT" % (len(mag), mag.mean(), mag.max() - mag.min()))
    return 0
