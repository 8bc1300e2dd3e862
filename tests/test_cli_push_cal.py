"""`fluxcal push-cal` against the live virtual handheld: the round trip, the firmware's own refusal,
a pushed response, and the calibration it replaces kept in a file (the wrong file pushed is one
push-cal from undone). Its refusals before anything is sent: tests/test_cli_device.py."""

import json

import numpy as np

from tests.test_cli_device import fails_in_one_line, fluxcal, handheld, ok  # noqa: F401 - the fixture


def _kept(out):
    """The file push-cal kept the replaced calibration in (its last line names it), or None."""
    line = out.strip().splitlines()[-1]
    if "the calibration it replaced is in " not in line:
        return None
    return line.split("the calibration it replaced is in ")[1].split(":")[0]


def test_push_cal_round_trip_and_the_firmware_s_refusal(handheld, tmp_path):
    from desktop.formats.calibration import load_calibration, to_code_units

    k = 0.0144243258    # nT per code: device/config.py's scale_x/y/z
    fitted = {"matrix": [[1.001, 0.002, 0], [0.002, 0.998, 0], [0, 0, 1.0]], "offset": [120.0, -35.5, 60.25],
              "field": 47200.0, "diagnostics": {"rms": 0.2, "n": 900}, "meta": {"method": "streaming"}}
    (tmp_path / "fitted.json").write_text(json.dumps(fitted))
    out = ok(fluxcal("push-cal", tmp_path / "fitted.json", "--port", handheld.port))
    assert "converted from nT" in out
    ok(fluxcal("pull-cal", "-o", tmp_path / "a.json", "--port", handheld.port))
    out = ok(fluxcal("push-cal", tmp_path / "a.json", "--port", handheld.port))
    assert _kept(out) is None             # the same calibration in force: nothing to keep
    ok(fluxcal("pull-cal", "-o", tmp_path / "b.json", "--port", handheld.port))
    a, b = load_calibration(tmp_path / "a.json"), load_calibration(tmp_path / "b.json")
    expect = to_code_units(load_calibration(tmp_path / "fitted.json"), [k] * 3)
    for cal in (a, b):
        assert np.allclose(cal.matrix, expect.matrix, rtol=1e-12) and np.allclose(cal.offset, expect.offset, rtol=1e-12)
        assert cal.field == 47200.0 and cal.meta["units"] == "codes"
    # plausible here, refused by the firmware's own checks: gains 10x the front end's
    (tmp_path / "ten.json").write_text(json.dumps(dict(fitted, matrix=[[10, 0, 0], [0, 10, 0], [0, 0, 10]])))
    fails_in_one_line(fluxcal("push-cal", tmp_path / "ten.json", "--port", handheld.port), "bad_scale")
    ok(fluxcal("pull-cal", "-o", tmp_path / "c.json", "--port", handheld.port))
    assert np.allclose(load_calibration(tmp_path / "c.json").matrix, a.matrix)   # the previous one stays
    assert not list(tmp_path.glob("replaced-*.json"))     # and no copy of it is left behind


def test_a_pushed_response_is_what_the_survey_de_lags_with(handheld, tmp_path):
    """A record from `fluxcal fit --lag` carries per-axis taus: the handheld's survey output
    undoes the lag with them (status delag_us, whole us); one without a response is applied to
    the samples as read (the Mag649's config: its lag needs no undoing)."""
    fitted = {"matrix": [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]], "offset": [0.0, 0.0, 0.0], "field": 47200.0,
              "meta": {"method": "streaming"},
              "response": {"model": "first-order", "tau_s": [0.0318, 0.032, 0.0316], "source": "estimated"}}
    (tmp_path / "lag.json").write_text(json.dumps(fitted))
    out = ok(fluxcal("push-cal", tmp_path / "lag.json", "--port", handheld.port))
    assert "its survey output de-lagged with tau 31.800, 32.000, 31.600 ms" in out
    st = json.loads(ok(fluxcal("status", "--json", "--port", handheld.port)))["status"]
    assert st["delag_us"] == [31800, 32000, 31600]
    del fitted["response"]
    (tmp_path / "plain.json").write_text(json.dumps(fitted))
    out = ok(fluxcal("push-cal", tmp_path / "plain.json", "--port", handheld.port))
    assert "de-lagged" not in out
    assert json.loads(ok(fluxcal("status", "--json", "--port", handheld.port)))["status"]["delag_us"] is None
    # the one it replaced, kept beside plain.json, puts the de-lag back
    kept = _kept(out)
    assert kept and (tmp_path / kept.rsplit("/", 1)[-1]).exists(), out
    ok(fluxcal("push-cal", tmp_path / kept.rsplit("/", 1)[-1], "--port", handheld.port))
    st = json.loads(ok(fluxcal("status", "--json", "--port", handheld.port)))["status"]
    assert st["delag_us"] == [31800, 32000, 31600]
