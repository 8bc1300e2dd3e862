"""fluxcal correct CAL.json RAW -o OUT.csv [--columns X,Y,Z --unit U --scale K --skip N] [--rate SPS]

A calibration that carries a response (fluxcal fit --lag) has the readings' lag undone
first (desktop.methods.lag.delag), which needs their times: a capture's, the log's time
column, or --rate.
"""

from desktop.cli._lag_options import add_lag_arguments, sample_times
from desktop.cli._log_options import add_log_arguments, log_format

HELP = "apply a calibration: write x,y,z,magnitude in nT"


def add_arguments(p):
    p.add_argument("calibration", help="calibration JSON written by `fluxcal fit`")
    p.add_argument("raw", help="magnetometer log (CSV or whitespace-separated; see --columns, --unit) or a capture .npz")
    p.add_argument("-o", "--output", required=True, help="CSV to write (x,y,z,magnitude)")
    add_log_arguments(p)
    add_lag_arguments(p, lag=False)


def run(args):
    from desktop.formats.calibration import load_calibration
    from desktop.formats.readings import read_log, write_corrected
    from desktop.methods import correct_array
    from desktop.methods.lag import delag

    cal = load_calibration(args.calibration)
    h, t = read_log(args.raw, log_format(args))
    if cal.response is not None:
        h = delag(h, sample_times(args, args.raw, len(h), t), cal.response["tau_s"])
    corrected = correct_array(cal, h)
    write_corrected(args.output, corrected)
    mag = (corrected ** 2).sum(axis=1) ** 0.5
    print("%d rows: |B| mean %.3f nT, peak-to-peak %.3f nT" % (len(mag), mag.mean(), mag.max() - mag.min()))
    return 0
