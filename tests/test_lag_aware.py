"""De-lagging a slow sensor (desktop/methods/lag.py), the record's response
(shared/response.py) and `fluxcal fit --lag` / `fluxcal correct` with it."""

import json
import math

import numpy as np
import pytest

from desktop.cli import main
from desktop.experiments.common import capture_nT
from desktop.methods.lag import PRIOR_SHARE, delag, estimate_response
from desktop.sim.scenario import Scenario
from shared.calibration import Calibration

SPS = 1000
# the ADS1292's sinc3 at 1000 SPS averages over three 1 ms boxcars (time variance 3 / 12 ms^2):
# a turning vector's average shrinks as if lagged by sigma_t more, tau_eff = sqrt(tau^2 + sigma_t^2)
SINC3_SIGMA_S = math.sqrt(3.0 / 12.0) / SPS


def test_delag_undoes_a_first_order_lag_on_a_steady_spin():
    # ideal, noise-free Mag648 spun at 1 rev/s: |y| is low by ~B (tau w)^2 / 2 (940 nT here);
    # de-lagged, the mean is left with the sinc3's smear B (w sigma_t)^2 / 2 (0.24 nT) and
    # the PTP with the codes' rounding amplified by tau / dt (a few hundredths of a nT)
    h, cap = capture_nT(motion="spin", rot_rate=1.0, seconds=3.0, rate=SPS, ideal=True, noise=0.0, adc_noise=False,
                        inclination_deg=0.0, sensor="mag648", field_nT=48000.0)
    tau = 1.0 / (2 * math.pi * 5.0)
    steady = (cap["t"] > 1.0) & (cap["t"] < cap["t"][-1] - 0.02)   # not the derivative's one-sided ends
    raw = np.linalg.norm(h[steady], axis=1)
    fixed = np.linalg.norm(delag(h, cap["t"], tau)[steady], axis=1)
    assert 48000.0 - raw.mean() > 900.0
    assert abs(fixed.mean() - 48000.0) < 1.0
    assert np.ptp(fixed) < 0.5


def _estimate(prior=None, **kw):
    sc = dict(sensor="mag648", rate=SPS, seconds=40.0, seed=5, rot_rate=0.5)
    sc.update(kw)
    h, cap = capture_nT(**sc)
    return estimate_response(h, cap["t"], prior=prior), Scenario(**sc).fluxgate().tau()


def test_estimate_finds_each_axis_time_constant():
    # axes' bandwidths within 3 %: their taus differ by up to 2 ms, and the estimate must
    # see each to within its own 4 sigma (after the sinc3's share, SINC3_SIGMA_S)
    est, tau = _estimate(bandwidth_spread=0.03)
    truth = np.sqrt(tau ** 2 + SINC3_SIGMA_S ** 2)
    assert np.ptp(truth) > 1e-3
    assert np.all(np.abs(est["tau_s"] - truth) < 4 * est["tau_sigma_s"] + 1e-6)
    assert np.all(est["tau_sigma_s"] < 0.01 * truth)
    assert est["identified"] and est["model_ok"] and est["message"] == ""


def test_a_two_pole_response_is_named_not_first_order():
    est, _ = _estimate(poles=2)
    assert not est["model_ok"]
    assert "not first order" in est["message"]


def test_a_lag_too_small_to_see_is_said_so():
    # the Mag649's 0.16 ms and the sinc3's 0.5 ms shrink |B| by B (tau w)^2 / 2 ~ 3e-4 nT at
    # 0.1 rev/s, far below the 0.1 nT noise of a sample: no estimate can tell it from zero
    est, _ = _estimate(sensor="mag649", rot_rate=0.1)
    assert not est["identified"]
    assert "turned too slowly" in est["message"]
    # a configured tau then stands, with its own uncertainty
    est, _ = _estimate(sensor="mag649", rot_rate=0.1, prior=2e-4)
    assert not est["identified"] and "the configured 0.200 ms kept" in est["message"]
    assert np.allclose(est["tau_s"], 2e-4) and np.allclose(est["tau_sigma_s"], 2e-4 * PRIOR_SHARE)


def test_the_sinc3_lag_is_seen_on_the_mag649_turned_fast():
    # at 1 rev/s the ADC's own averaging (sinc3: tau_eff = sqrt(tau^2 + sigma_t^2) = 0.52 ms)
    # shrinks |B| by ~0.2 nT at the hand's fastest, over 120,000 samples of 0.1 nT noise
    est, tau = _estimate(sensor="mag649", rot_rate=1.0)
    truth = np.sqrt(tau ** 2 + SINC3_SIGMA_S ** 2)
    assert est["identified"]
    assert np.all(np.abs(est["tau_s"] - truth) < 4 * est["tau_sigma_s"])


def test_a_configured_tau_20_percent_off_is_refined_by_the_data():
    # the Mag648's 5 Hz configured as 4 Hz: the data see the lag to 0.01 % and decide
    est, tau = _estimate(prior=1.25 * 1.0 / (2 * math.pi * 5.0))
    truth = np.sqrt(tau ** 2 + SINC3_SIGMA_S ** 2)
    assert est["identified"] and est["message"] == ""
    assert np.all(np.abs(est["tau_s"] - truth) < 4 * est["tau_sigma_s"] + 1e-6)
    assert np.all(est["tau_sigma_s"] < 1e-3 * truth)


def _record(**extra):
    d = {"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "offset": [0, 0, 0], "field": 48000.0}
    d.update(extra)
    return d


def test_record_carries_the_response_and_old_records_load():
    old = Calibration.from_dict(_record())
    assert old.response is None and "response" not in old.to_dict()
    resp = {"model": "first-order", "tau_s": [0.03, 0.031, 0.032], "tau_sigma_s": [1e-5] * 3, "source": "estimated"}
    cal = Calibration.from_dict(_record(response=resp))
    again = Calibration.from_dict(json.loads(json.dumps(cal.to_dict())))
    assert again.response == resp
    assert again.scaled_input(0.01).response == resp
    for bad, words in (({"model": "two-pole", "tau_s": [0.03] * 3}, "response.model"),
                       ({"model": "first-order", "tau_s": [-0.01, 0, 0]}, "response.tau_s[0]"),
                       ({"model": "first-order", "tau_s": [0.03] * 2}, "list of 3"),
                       ({"model": "first-order"}, "no 'tau_s'")):
        with pytest.raises(ValueError, match=words.replace("[", r"\[").replace("]", r"\]")):
            Calibration.from_dict(_record(response=bad))


def test_fit_with_lag_and_correct_through_the_cli(tmp_path, capsys):
    fit_npz, cal_json, out = (str(tmp_path / n) for n in ("fit.npz", "cal.json", "out.csv"))
    assert main(["simulate", "--sensor", "mag648", "--seed", "5", "--rate", str(SPS), "--rot-rate", "0.5",
                 "--seconds", "40", "-o", fit_npz]) == 0
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "auto"]) == 0
    text = capsys.readouterr().out
    assert "lag undone (first order, estimated)" in text
    cal = json.load(open(cal_json))
    assert cal["response"]["source"] == "estimated"
    assert cal["diagnostics"]["tau_error"] > 0
    assert main(["correct", cal_json, fit_npz, "-o", out]) == 0
    # the same readings as a CSV without times: correct asks for the rate, then takes it
    csv = str(tmp_path / "raw.csv")
    h, _ = capture_nT(sensor="mag648", rate=SPS, seconds=2.0, seed=5)
    np.savetxt(csv, h, delimiter=",", header="x,y,z", comments="")
    capsys.readouterr()
    assert main(["correct", cal_json, csv, "-o", out]) == 1
    assert "--rate" in capsys.readouterr().err
    assert main(["correct", cal_json, csv, "-o", out, "--rate", str(SPS)]) == 0
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "fast"]) == 1
    assert "--lag must be auto or a time constant" in capsys.readouterr().err


def test_a_given_lag_is_written_as_given(tmp_path, capsys):
    fit_npz, cal_json = str(tmp_path / "fit.npz"), str(tmp_path / "cal.json")
    assert main(["simulate", "--sensor", "mag648", "--seed", "5", "--rate", str(SPS), "--rot-rate", "0.2",
                 "--seconds", "20", "-o", fit_npz]) == 0
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "0.0318", "--accept-anyway"]) == 0
    resp = json.load(open(cal_json))["response"]
    assert resp["source"] == "given" and resp["tau_s"] == [0.0318] * 3


def test_fit_refuses_a_response_it_cannot_represent(tmp_path, capsys):
    fit_npz, cal_json = str(tmp_path / "fit.npz"), str(tmp_path / "cal.json")
    assert main(["simulate", "--sensor", "mag648", "--poles", "2", "--seed", "5", "--rate", str(SPS),
                 "--rot-rate", "0.5", "--seconds", "40", "-o", fit_npz]) == 0
    capsys.readouterr()
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "auto"]) == 1
    err = capsys.readouterr().err
    assert "calibration refused (response_not_first_order)" in err and "not first order" in err
    assert not (tmp_path / "cal.json").exists()


def test_experiment_reaches_the_mag648_target_at_half_a_rev_per_second(tmp_path):
    # the target: Mag648 turned at 0.5 rev/s, de-lagged, spin PTP <= 1 nT (0.1 s average)
    from desktop.experiments.lag_aware import run
    run(str(tmp_path), cases=(("Mag648", [], ["auto"], (0.5,)),))
    row = next(line for line in (tmp_path / "lag_aware.md").read_text().splitlines() if line.startswith("| Mag648 |"))
    cells = [c.strip() for c in row.split("|")[1:-1]]
    assert cells[3] == "accepted"
    assert float(cells[5]) <= 1.0
    assert abs(float(cells[4]) - 31.83) < 0.05          # tau (ms) of 5 Hz, the sinc3's 0.004 ms within


def _residual_rms(text):
    return float(text.split("residual rms ")[1].split(" nT")[0])


def test_report_undoes_the_lag_the_calibration_carries(tmp_path, capsys):
    # Mag648 turned at 0.5 rev/s: its lag reads |B| low by up to B (tau w)^2 / 2, hundreds of
    # nT at the hand's fastest; de-lagged, the residual is the noise amplified by the
    # derivative (a few nT). The same calibration without its response must read far worse.
    fit_npz, cal_json, bare_json = (str(tmp_path / n) for n in ("fit.npz", "cal.json", "bare.json"))
    assert main(["simulate", "--sensor", "mag648", "--seed", "5", "--rate", str(SPS), "--rot-rate", "0.5",
                 "--seconds", "20", "-o", fit_npz]) == 0
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "0.0318", "--accept-anyway"]) == 0
    record = json.load(open(cal_json))
    del record["response"]
    json.dump(record, open(bare_json, "w"))
    capsys.readouterr()
    assert main(["report", fit_npz, "--cal", cal_json, "-o", str(tmp_path / "r1")]) == 0
    delagged = _residual_rms(capsys.readouterr().out)
    assert "lag undone (tau 31.800" in (tmp_path / "r1" / "summary.md").read_text()
    assert main(["report", fit_npz, "--cal", bare_json, "-o", str(tmp_path / "r2")]) == 0
    lagging = _residual_rms(capsys.readouterr().out)
    assert delagged < 5.0 and lagging > 10 * delagged


def test_report_leaves_out_the_de_lags_one_sided_ends(tmp_path, capsys):
    # the derivative's first and last 2k samples are one-sided differences (desktop/methods/lag.py):
    # where a recording starts and ends mid-turn they read |B| off by ~tau w^2 B k dt / 3 (the
    # centripetal h'' lies along h), and a report that kept them gave their peak-to-peak as the
    # calibration's (8.4 nT for a stream's 0.3 nT on the virtual handheld's capture)
    from desktop.formats.readings import LogFormat, read_log
    from desktop.methods import correct_array
    from desktop.methods.lag import derivative, span_samples

    fit_npz, cal_json, log = str(tmp_path / "fit.npz"), str(tmp_path / "cal.json"), str(tmp_path / "turning.csv")
    assert main(["simulate", "--sensor", "mag649", "--seed", "5", "--rate", str(SPS), "--rot-rate", "1",
                 "--seconds", "20", "--bandwidth", "220", "-o", fit_npz]) == 0
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "0.000723", "--accept-anyway"]) == 0
    h, _ = read_log(fit_npz, LogFormat())
    t = np.load(fit_npz)["t"]
    # a log cut where the hand turns fastest, in its first and its last third
    rate = np.linalg.norm(derivative(h, t), axis=1)
    n = len(h)
    a = int(np.argmax(rate[: n // 3]))
    b = 2 * n // 3 + int(np.argmax(rate[2 * n // 3:])) + 1
    np.savetxt(log, np.column_stack([t[a:b], h[a:b]]), delimiter=",", header="t,x,y,z", comments="")
    capsys.readouterr()
    assert main(["report", log, "--cal", cal_json, "-o", str(tmp_path / "r")]) == 0
    reported = float(capsys.readouterr().out.split("peak-to-peak ")[1].split(" nT")[0])
    cal = Calibration.from_dict(json.load(open(cal_json)))
    resid = np.linalg.norm(correct_array(cal, delag(h[a:b], t[a:b], cal.response["tau_s"])), axis=1) - cal.field
    edge = 2 * span_samples(t[a:b])
    assert "its first and last %d samples (one-sided) left out" % edge in (tmp_path / "r" / "summary.md").read_text()
    assert reported == pytest.approx(np.ptp(resid[edge:-edge]), abs=1e-3)
    assert np.ptp(resid) > 2 * reported        # what the ends alone added


def test_fit_names_a_response_it_cannot_identify_and_takes_a_configured_one(tmp_path, capsys):
    fit_npz, cal_json = str(tmp_path / "fit.npz"), str(tmp_path / "cal.json")
    assert main(["simulate", "--sensor", "mag649", "--seed", "5", "--rate", str(SPS), "--rot-rate", "0.1",
                 "--seconds", "20", "-o", fit_npz]) == 0
    capsys.readouterr()
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "auto"]) == 0
    assert "warning: response_not_identified: the lag was not seen" in capsys.readouterr().err
    # 20 s at 0.1 rev/s covers little of the sphere: the prior's 50 % may cost more than 5 nT
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "auto", "--lag-prior", "0.0005", "--accept-anyway"]) == 0
    assert "the configured 0.500 ms kept" in capsys.readouterr().err
    resp = json.load(open(cal_json))["response"]
    assert resp["tau_s"] == [0.0005] * 3 and resp["prior_s"] == 0.0005
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "0.0005", "--lag-prior", "0.0005"]) == 1
    assert "give it with --lag auto" in capsys.readouterr().err
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "auto", "--lag-prior", "auto"]) == 1
    assert "--lag-prior must be a time constant" in capsys.readouterr().err


@pytest.mark.parametrize("sensor, rev", [("mag648", "0.5"), ("mag649", "1.0")])
def test_a_de_lagged_fit_predicts_its_real_error_within_a_factor_two(tmp_path, sensor, rev):
    # both figures are rms over the sphere; one recording's real error scatters about the
    # expected by a chi of the ~9 calibration parameters (+-40 % at 2 sigma), within the
    # issue's factor 2 when the prediction counts what the taus' uncertainty really is
    from desktop.experiments.lag import sphere_error
    from desktop.formats.calibration import load_calibration
    from desktop.formats.capture import load_capture
    fit_npz, cal_json = str(tmp_path / "fit.npz"), str(tmp_path / "cal.json")
    assert main(["simulate", "--sensor", sensor, "--seed", "5", "--rate", str(SPS), "--rot-rate", rev,
                 "--seconds", "40", "-o", fit_npz]) == 0
    assert main(["fit", fit_npz, "-o", cal_json, "--lag", "auto"]) == 0
    cal = load_calibration(cal_json)
    ratio = cal.diagnostics["predicted_error"] / sphere_error(cal, load_capture(fit_npz), False)
    assert 0.5 <= ratio <= 2.0
