"""Figs. 7 and 8: PTP and variance after calibration vs sphere coverage, sigma 0.1 and 0.3 nT.

The paper's synthetic setup (section IV.D): points sampled uniformly over the
covered part of the sphere, sensor noise sigma, no ADC, calibrated with its
neural network; scored over the whole sphere. Here: the `cap` motion (attitudes
uniform over a cap of the given area fraction, held 10 ms each; only
conversions 6 ms or more after a jump are kept: sinc3 and sensor settled), the ADS1292's own
noise switched off, scored on a held-out uniform full-sphere capture of the
same sensor. Both coverage measures are reported: the paper's (area share of
0.01 x 0.01 rad (theta, phi) cells holding a sample) and this project's
(share of shared.coverage's 384 equal-area cells).
"""

import numpy as np

from desktop.experiments.common import (capture_nT, figure, fit, out_path, paper_coverage,
                                        project_coverage, score, write_table)

COVERAGES = (0.1, 0.2, 0.26, 0.4, 0.6, 0.8, 1.0)
SIGMAS = (0.1, 0.3)
RATE, DWELL = 1000, 0.01


def _settled(motion, coverage, sigma, motion_seed, seconds):
    h, cap = capture_nT(motion=motion, coverage=coverage, noise=sigma, rate=RATE, dwell=DWELL,
                        seconds=seconds, adc_noise=False, seed=0, motion_seed=motion_seed, truth=True)
    t = cap["t"]
    # keep conversions >= 6 ms after a jump: the sinc3 window (3 ms) saw one attitude
    # and the 1 kHz sensor low-pass (tau 0.16 ms) has settled to e^-18
    keep = np.mod(t + 1e-9, DWELL) >= 0.006
    return h[keep], cap["field_true"][keep]


def run(out):
    res = {}
    for sigma in SIGMAS:
        test, _ = _settled("uniform", 1.0, sigma, 99, 8.0)
        for cov in COVERAGES:
            cal, truth = _settled("cap", cov, sigma, 1, 8.0)
            row = {"paper_cov": paper_coverage(truth), "project_cov": project_coverage(truth)}
            for method in ("paper-nn", "streaming"):
                try:
                    row[method] = score(fit(cal, method), test)
                except Exception as exc:                     # a fit may refuse a tiny cap
                    row[method] = (float("nan"), float("nan"))
                    row[method + "_error"] = str(exc)
            res[(sigma, cov)] = row
    plt = figure()
    for k, (name, unit, fig_name) in enumerate((("PTP", "nT", "fig7"), ("variance", "nT^2", "fig8"))):
        fig, ax = plt.subplots(figsize=(6, 4))
        for sigma, style in zip(SIGMAS, ("-", "--")):
            for method, mk in (("paper-nn", "o"), ("streaming", "s")):
                ax.semilogy([100 * c for c in COVERAGES], [res[(sigma, c)][method][k] for c in COVERAGES],
                            mk + style, label="%s, sigma %.1f nT" % ("paper NN" if method == "paper-nn" else "ours", sigma))
        ax.axvline(26, color="grey", lw=0.5)
        ax.set_xlabel("coverage of the sphere (%, cap area)")
        ax.set_ylabel("%s of |h_c| over the full sphere (%s)" % (name, unit))
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out_path(out, fig_name + ".png"), dpi=110)
    rows = []
    for sigma in SIGMAS:
        for cov in COVERAGES:
            r = res[(sigma, cov)]
            rows.append(["%.1f" % sigma, "%d" % round(100 * cov), "%.1f" % (100 * r["paper_cov"]),
                         "%.0f" % (100 * r["project_cov"]),
                         "%.2f / %.3f" % r["paper-nn"], "%.2f / %.3f" % r["streaming"]])
    header = ["sigma (nT)", "cap area (%)", "paper's coverage (%)", "project coverage (%)",
              "paper NN: PTP (nT) / Var (nT^2)", "ours: PTP / Var"]
    text = write_table(out_path(out, "fig7.md"), "Figs. 7 and 8: calibration vs coverage (full-sphere test)",
                       header, rows)
    with open(out_path(out, "fig8.md"), "w") as fh:
        fh.write(text)
    return text
