"""The serial protocol through pyserial over a real pseudo-terminal (firmware in-process).

Every request gets exactly one machine-readable reply line; malformed,
oversized, binary and unknown input gets an error line and the device keeps
running. Nothing is mocked: the firmware's bytes go through os.openpty.
"""

import json

import pytest
import serial

from desktop.devicesim.client import Client
from desktop.devicesim.runners import start_device
from desktop.devicesim.world import make_world
from desktop.firmware.files import import_device
from desktop.sim.field import EARTH_NT
from shared import codes
from tests.device_session import on_pty
from tests.interpreters import INTERPRETERS, need


@pytest.fixture
def client(tmp_path):
    with on_pty(tmp_path, 5.0, timeout=1) as (w, dev, ser):
        c = Client(ser, dev)
        yield c
    assert c.junk == [], "non-JSON output on the serial line"


def test_version_and_status(client):
    v = client.ask("version")
    assert v["ok"] and v["v"] == 1 and v["proto"] == 1 and v["fw"]
    s = client.ask("status")
    assert s["ok"] and s["state"] == "survey" and s["calibrated"] is False
    assert s["frames"] > 0 and s["overflow"] == 0 and s["badsync"] == 0
    assert abs(s["temp"] - 25.0) < 0.5          # the emulator's die at 25 C, through the temp MUX
    # every conversion counted: between two readings the frames grow at the data rate, to a frame
    # at each end (ticks_ms is whole ms: 1 frame at the default 1000 SPS)
    later = client.ask("status", dt=1.0)
    rate = import_device("config").SCHEMA["rate"][0]
    grown = later["frames"] - s["frames"]
    assert abs(grown - rate * (later["uptime_ms"] - s["uptime_ms"]) / 1000) <= 2 * rate / 1000, (s, later)


@pytest.mark.parametrize("line, code", [
    ("frobnicate", "unknown_command"),
    ("stream sideways", "bad_argument"),
    ("config set rate 3000", "bad_value"),        # not an ADS1292 rate
    ("config set gain_x 5", "bad_value"),          # not a PGA gain
    ("config set window 99", "bad_value"),         # window > decim
    ("config set nonsense 1", "unknown_key"),
    ("config set field_nt __import__('os')", "bad_value"),  # a bare word is a string, never code
    ("set-cal {not json", "bad_json"),
    ("set-cal {\"matrix\": [[1,0,0],[0,1,0],[0,0,1]], \"offset\": [0,0], \"field\": 1}", "bad_argument"),
    ("finish-cal", "not_calibrating"),
    ("cancel-cal", "not_calibrating"),
])
def test_errors_are_one_line_with_a_code(client, line, code):
    r = client.ask(line)
    assert r["ok"] is False and r["error"] == code and r["msg"]
    assert client.ask("status")["ok"]              # still alive


def test_oversized_binary_and_control_input(client):
    client.write(b"x" * 3000)
    client.step()
    client.write(b"x" * 2000 + b"\n")
    client.step()
    client.write(b"\xff\xfe\x00\x01garbage\n")
    client.step()
    client.write(b"status\x03\n")
    client.step()
    errs = [d["error"] for d in client.replies() if not d["ok"]]
    assert errs == ["line_too_long", "bad_encoding", "bad_request"]
    # a flood without newline is bounded and does not block the next command
    for _ in range(25):            # 100 kB, in pieces the pty buffer takes (nothing runs while we write)
        client.write(b"y" * 4000)
        client.step(0.01)
    client.write(b"\n")
    client.step()
    assert client.replies()[-1]["error"] == "line_too_long"
    r = client.ask("version")
    assert r["ok"] and r["cmd"] == "version"


def test_the_line_limit_is_the_one_the_laptop_checks(client):
    """A request of exactly MAX_LINE bytes is read (fluxcal push-cal sends up to that), one
    byte more is line_too_long: shared/codes.py's limit is the firmware's."""
    client.write(b"x" * codes.MAX_LINE + b"\n")
    client.step()
    client.write(b"x" * (codes.MAX_LINE + 1) + b"\n")
    client.step()
    assert [d["error"] for d in client.replies()] == [codes.UNKNOWN_COMMAND, codes.LINE_TOO_LONG]


def test_delag_adc_takes_auto_or_a_bool(client):
    """delag_adc: true, false or "auto" (on where DRDY is an interrupt: the simulated board's)."""
    assert client.ask("config get delag_adc")["value"] == "auto"
    assert client.ask("status", dt=0.2)["delag_us"] == [725] * 3     # uncalibrated: the configured response
    assert client.ask("config set delag_adc false")["value"] is False
    assert client.ask("status", dt=0.2)["delag_us"] is None          # a 1 kHz sensor: not slow
    r = client.ask("config set delag_adc maybe")
    assert r["ok"] is False and "true or false or auto" in r["msg"], r
    assert client.ask("config set delag_adc auto")["value"] == "auto"


def test_config_roundtrip_persists(client, tmp_path):
    assert client.ask("config set survey_hz 5")["value"] == 5
    assert client.ask("config get survey_hz")["value"] == 5
    assert client.ask("config set field_nt 48000")["value"] == 48000.0
    with open(tmp_path / "flash" / "config.json") as f:
        assert json.loads(f.readline()) == {"survey_hz": 5, "field_nt": 48000.0}
    r = client.ask("config set rate 2000")
    assert r["ok"]
    s = client.ask("status", dt=0.2)
    assert s["frames"] > 0 and s["fault"] is None


def test_stream_modes(client):
    assert client.ask("stream on raw")["stream"] == "raw"
    client.step(0.5)
    raw = client.events("raw")
    assert len(raw) >= 4 and all(len(d["c"]) == 3 for d in raw)
    # n numbers each block's last decimated sample: a block of rate / decim / survey_hz apart
    cfg = client.ask("config get")["config"]
    step = cfg["rate"] // cfg["decim"] // cfg["survey_hz"]
    assert all(b["n"] - a["n"] == step for a, b in zip(raw, raw[1:])), [d["n"] for d in raw]
    assert client.ask("stream corrected")["stream"] == "corrected"
    client.step(0.5)
    data = client.events("data")
    # uncalibrated |B| on the nominal scale: the sensor's gains (0.5 %), the front end's dividers
    # (2 %) and offsets (10 nT sensor, 2 mV = 100 nT front end, per axis) keep it within 3 % of the field
    assert data and data[-1]["cal"] is False and abs(data[-1]["f"] - EARTH_NT) < 0.03 * EARTH_NT, data[-1]
    assert client.ask("stream off")["ok"]
    n = len(client.events())
    client.step(0.5)
    assert len(client.events()) == n


def test_set_cal_validated_then_get_cal(client):
    k = 0.012983
    good = {"matrix": [[k, 0, 0], [0, k, 0], [0, 0, k]], "offset": [0, 0, 0], "field": 48000.0}
    assert client.ask("set-cal " + json.dumps(good))["ok"]
    got = client.ask("get-cal")["cal"]
    assert got["matrix"][1][1] == pytest.approx(k) and got["meta"]["source"] == "set-cal"
    # gains 10x off the configured front end are refused (a plausible matrix, the wrong scale);
    # the good one stays
    bad = dict(good, matrix=[[10 * k, 0, 0], [0, 10 * k, 0], [0, 0, 10 * k]])
    r = client.ask("set-cal " + json.dumps(bad))
    assert r["error"] == "bad_scale"
    assert client.ask("get-cal")["cal"]["matrix"][0][0] == pytest.approx(k)
    nan = dict(good, field=float("nan"))
    assert client.ask("set-cal " + json.dumps(nan))["error"] == "bad_argument"


def test_start_and_cancel(client):
    assert client.ask("start-cal")["ok"]
    assert client.ask("start-cal")["error"] == "busy"
    assert client.ask("config set rate 500")["error"] == "busy"
    assert client.ask("status")["state"] == "calibrating"
    assert client.ask("cancel-cal")["ok"]
    ev = client.events("cal")[-1]
    assert ev["state"] == "cancelled" and ev["reason"] == "cancelled"
    assert client.ask("status")["calibrated"] is False


@pytest.mark.parametrize("name", INTERPRETERS)
def test_protocol_on_each_interpreter_over_pty(name, tmp_path):
    """The same line protocol from the firmware running in each interpreter a board has."""
    need(name)
    w = make_world(serial="pty", motion="stationary", seconds=5.0, seed=6)
    dev = start_device(w, str(tmp_path), kind=name)
    try:
        dev.run_until(0.3)
        ser = serial.Serial(w.serial_port, timeout=1, exclusive=True)
        c = Client(ser, dev)
        v = c.ask("version")
        impl = "circuitpython" if name == "circuitpython" else "micropython"
        assert v["impl"] == impl and v["runtime"] == "sim-" + impl
        assert c.ask("nope")["error"] == "unknown_command"
        c.write(b"\xc3\x28\n")
        c.step()
        assert c.replies()[-1]["error"] == "bad_encoding"
        assert c.ask("config set decim 1")["error"] == "bad_value"   # window 2 > decim 1
        assert c.ask("config set decim 20")["ok"]
        s = c.ask("status", dt=0.3)
        assert s["frames"] > 0 and s["overflow"] == 0 and s["samples"] > 0
        assert c.junk == []
        ser.close()
    finally:
        dev.close()
