"""Lag-aware calibration through the CLI: the spin's PTP against the rotation rate, with and
without de-lagging (`fluxcal fit --lag`), for the paper's slow Mag648 and the cases around it.

    python -m desktop.experiments.lag_aware [--out DIR] [--quick]

Protocol, per case and rate: `fluxcal simulate` 120 s of hand rotation at 1000 SPS (seed 5,
motion seed 1) and a 30 s spin at the same rate (motion seed 2); `fluxcal fit` on the
first (--accept-anyway, so that a refused fit is still scored; its refusal is shown),
`fluxcal correct` on the spin; the PTP of |B| after the paper's 0.1 s moving average. The
predicted error is the one `fluxcal fit` writes; the real one is the calibration's
full-sphere error on lag-free readings (desktop.experiments.lag.sphere_error, the field
fitted: B det(A)^(1/3) is the reference).
"""

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

from desktop.experiments.common import moving_average, out_path, write_table
from desktop.experiments.lag import sphere_error

RATES_REV_S = (0.1, 0.5, 1.0)
SPS = 1000
SEED = 5
TAU_648 = 1.0 / (2.0 * np.pi * 5.0)
# (label, simulate options, fit's --lag values (None: no de-lagging; words after the value are
# further options), rates)
CASES = (
    ("Mag648", [], [None, "auto"], RATES_REV_S),
    ("Mag648, bandwidth configured 20 % low (4 Hz)", [],
     ["%.5f" % (TAU_648 * 1.25), "auto --lag-prior %.5f" % (TAU_648 * 1.25)], (0.5, 1.0)),
    ("Mag648, axes' bandwidths within 3 %", ["--bandwidth-spread", "0.03"], [None, "auto"], (0.5, 1.0)),
    ("Mag648 with two poles (same -3 dB)", ["--poles", "2"], [None, "auto"], (0.5, 1.0)),
    ("Mag649", ["--sensor", "mag649"], [None, "auto"], (0.5, 1.0)),
    ("paper preset", ["--sensor", "paper"], [None, "auto"], (0.5, 1.0)),
)
STATISTICS = ("Predicted and real are the same statistic: the rms over the sphere of the calibration's error "
              "of |B|. The spin PTP is another: the peak-to-peak of 30 s of |B| after the 0.1 s average, mostly "
              "the noise that the average and the de-lagging leave.")
PAPER_MAG648 = "29-38 nT PTP (Table 1: 38 nT at 250 Hz, 29 nT at 1000 Hz)"


def cli(*argv):
    """Run `fluxcal ARGV` (python -m desktop, this interpreter); (exit code, stdout, stderr)."""
    p = subprocess.run([sys.executable, "-m", "desktop"] + [str(a) for a in argv], capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def spin_ptp(csv_path, rate=SPS):
    """PTP (nT) of the corrected |B| column after the 0.1 s moving average."""
    mag = np.loadtxt(csv_path, delimiter=",", skiprows=1, usecols=3)
    return float(np.ptp(moving_average(mag[:, None], rate)[:, 0]))


def run_case(work, sim, lag, rev):
    """One row's figures: dict of verdict, tau_ms, ptp, predicted, real, commands."""
    from desktop.formats.calibration import load_calibration
    from desktop.formats.capture import load_capture
    tag = "%s_%s_%g" % ("_".join(sim).replace("-", "") or "mag648", str(lag).replace(" --", "_").replace(" ", "_"), rev)
    fit_npz, spin_npz = os.path.join(work, "fit_%s.npz" % tag), os.path.join(work, "spin_%s.npz" % tag)
    cal_json, out_csv = os.path.join(work, "cal_%s.json" % tag), os.path.join(work, "out_%s.csv" % tag)
    base = ([] if "--sensor" in sim else ["--sensor", "mag648"]) + sim + ["--seed", SEED, "--rate", SPS, "--rot-rate", rev]
    sim_fit = ["simulate"] + base + ["--seconds", 120, "-o", fit_npz]
    sim_spin = ["simulate"] + base + ["--seconds", 30, "--motion", "spin", "--motion-seed", 2, "-o", spin_npz]
    fit = ["fit", fit_npz, "-o", cal_json, "--accept-anyway"] + ([] if lag is None else ["--lag"] + lag.split())
    for argv in (sim_fit, sim_spin):
        code, _, err = cli(*argv)
        if code:
            raise RuntimeError(err)
    code, out, err = cli(*fit)
    if code:
        return {"verdict": "failed: " + err.strip().replace("fluxcal: ", ""), "commands": (sim_fit, sim_spin, fit)}
    warning = [line for line in err.splitlines() if "warning" in line]
    code, _, err = cli("correct", cal_json, spin_npz, "-o", out_csv)
    if code:
        raise RuntimeError(err)
    cal = load_calibration(cal_json)
    tau = cal.response["tau_s"] if cal.response else None
    refusal = next((w.split(":")[2].strip() for w in warning if "written anyway" in w), None)
    return {"verdict": "refused (%s)" % refusal if refusal else
            ("accepted, warned" if warning else "accepted"),
            "warning": " ".join(warning).replace("fluxcal: warning: ", ""),
            "tau_ms": None if tau is None else 1e3 * float(np.mean(tau)),
            "ptp": spin_ptp(out_csv), "predicted": cal.diagnostics.get("predicted_error"),
            "real": sphere_error(cal, load_capture(fit_npz), False), "commands": (sim_fit, sim_spin, fit)}


def _command_text(argv):
    return "fluxcal " + " ".join(os.path.basename(str(a)) if str(a).endswith((".npz", ".json")) else str(a)
                                 for a in argv)


def run(out, cases=CASES, quick=False):
    """Write lag_aware.md to out; returns its text."""
    rows, notes = [], []
    with tempfile.TemporaryDirectory() as work:
        for label, sim, lags, rates in cases:
            for rev in (rates[1:2] if quick else rates):
                for lag in lags:
                    r = run_case(work, sim, lag, rev)
                    if "ptp" not in r:
                        rows.append([label, "%.1f" % rev, lag or "none", r["verdict"], "", "", "", "", ""])
                        continue
                    ratio = r["predicted"] / r["real"] if r["predicted"] and r["real"] else float("nan")
                    rows.append([label, "%.1f" % rev, lag or "none", r["verdict"],
                                 "" if r["tau_ms"] is None else "%.3f" % r["tau_ms"], "%.2f" % r["ptp"],
                                 "%.3f" % r["predicted"], "%.3f" % r["real"], "%.2f" % ratio])
                    if r.get("warning"):
                        notes.append("- %s, %.1f rev/s, --lag %s: %s" % (label, rev, lag or "none", r["warning"]))
            notes.append("- %s: `%s`" % (label, "` then `".join(_command_text(c) for c in r["commands"])))
    text = write_table(out_path(out, "lag_aware.md"),
                       "Spin PTP (0.1 s moving average) after a fit on 120 s of hand rotation, 1000 SPS, seed 5: "
                       "with and without de-lagging (fluxcal fit --lag)",
                       ["sensor", "rev/s", "--lag", "fluxcal fit", "tau (ms, mean of axes)", "spin PTP (nT)",
                        "predicted (nT)", "real full-sphere (nT)", "predicted / real"], rows,
                       notes="Paper, Mag648: %s. Mag648 tau = %.2f ms (5 Hz).\n\n%s\n\n%s"
                             % (PAPER_MAG648, 1e3 * TAU_648, STATISTICS, "\n".join(notes)))
    return text


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.experiments.lag_aware", description=__doc__.splitlines()[0])
    p.add_argument("--out", default=os.path.join("docs", "experiments"), help="directory of lag_aware.md")
    p.add_argument("--quick", action="store_true", help="0.5 rev/s only")
    args = p.parse_args(argv)
    print(run(args.out, quick=args.quick))


if __name__ == "__main__":
    main()
