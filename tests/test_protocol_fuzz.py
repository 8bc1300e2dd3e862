"""The command parser fuzzed on the real `micropython` over a pseudo-terminal (issue 10).

desktop/bench/fuzz_grammar.py holds the grammar (commands from device/commands.py's TABLE
with generated arguments, set-cal records mutated field by field, config keys of
device/config.py's SCHEMA with generated values, bytes, long lines, floods) and
desktop/bench/fuzz_harness.py the harness: one firmware over a pty, and after each case,
the properties:

- every request line gets exactly one reply line (ok true, or ok false with an error
  code and a message; never internal_error), nothing but JSON on the line;
- the firmware keeps running: the `version` sent after the case answers;
- after a set-cal it accepted, the survey streams corrected data, finite or null.

Here hypothesis draws the cases (a bounded number, the same ones each run, a
failing input printed exactly); `python -m desktop.bench.fuzz --cases 20000` is the long run.
The inputs the issue found are pinned as examples of their own.
"""

import json

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from desktop.bench import fuzz_grammar as grammar
from desktop.bench.fuzz_harness import Harness


class HypothesisDraw:
    """The grammar's draw interface over hypothesis' data.draw."""

    def __init__(self, data):
        self.data = data

    def pick(self, seq):
        return self.data.draw(st.sampled_from(seq))

    def int(self, lo, hi):
        return self.data.draw(st.integers(lo, hi))

    def real(self, lo, hi):
        return self.data.draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))

    def chance(self, p):
        return self.data.draw(st.floats(0.0, 1.0)) < p

    def raw(self, most):
        return self.data.draw(st.binary(max_size=most))

    def order(self, n):
        return self.data.draw(st.permutations(list(range(n))))


@pytest.fixture(scope="module")
def harness(tmp_path_factory, micropython):
    h = Harness(str(tmp_path_factory.mktemp("fuzz")), kind="micropython")
    yield h
    h.close()


def run_case(harness, data):
    problems = harness.check(data)
    assert not problems, "input %r:\n%s" % (data if len(data) < 400 else data[:400] + b"...", "\n".join(problems))


# derandomize: the same cases every run (CI); the long random run is the script's. No
# shrinking: each try costs a firmware round trip, and a failure prints its exact input.
FUZZ = settings(max_examples=300, deadline=None, derandomize=True, database=None,
                phases=(Phase.explicit, Phase.generate), suppress_health_check=list(HealthCheck))


@FUZZ
@given(st.data())
def test_fuzz_commands_with_generated_arguments(harness, data):
    """Every command of the table but repl, its arguments JSON of any kind (deep, huge,
    NaN and Infinity spelled out), bare words, padding."""
    run_case(harness, grammar.case(HypothesisDraw(data), "command"))


@settings(FUZZ, max_examples=500)
@given(st.data())
def test_fuzz_set_cal_records_mutated_field_by_field(harness, data):
    """A record the firmware accepts, then up to three fields replaced: wrong types,
    nested meta and diagnostics, 1e-3 / 1e308 fields, 1e12 offsets, skewed, reversed and
    swapped axes, 10**400, NaN. Accepted or refused with a code; the survey streams."""
    run_case(harness, grammar.case(HypothesisDraw(data), "set-cal"))


@settings(FUZZ, max_examples=500)
@given(st.data())
def test_fuzz_config_keys_with_generated_values(harness, data):
    """config set / get of every SCHEMA key: valid, edge and out-of-range values, 1e309,
    400-digit integers, strings, objects."""
    run_case(harness, grammar.case(HypothesisDraw(data), "config"))


@settings(FUZZ, max_examples=300)
@given(st.data())
def test_fuzz_bytes_long_lines_and_floods(harness, data):
    """Random bytes (NUL, Ctrl-C, invalid UTF-8, lone CR), lines at and past 2048 bytes,
    floods of up to 60 lines and 6 kB without a newline, several cases in one burst."""
    d = HypothesisDraw(data)
    run_case(harness, grammar.case(d, d.pick(["bytes", "long", "flood", "mixed"]), flood_max=60))


K = grammar.K
GOOD = {"version": 1, "matrix": [[K, 0.0, 0.0], [0.0, K, 0.0], [0.0, 0.0, K]], "offset": [10.0, -20.0, 30.0],
        "field": 48000.0, "meta": {"temperature_c": 25.0, "scale": [K, K, K]}}


def set_cal(**changes):
    rec = json.loads(json.dumps(GOOD))
    for path, value in changes.items():
        *head, last = path.split("__")
        d = rec
        for k in head:
            d = d[k]
        d[last] = value
    return "set-cal " + grammar.dumps(rec)


# The inputs issue 10 found, and the kinds of the brief; each one line, one reply, alive.
PINNED = {
    # row 1: a string where meta.temperature_c belongs was stored and bricked the survey
    "meta.temperature_c a string": set_cal(meta__temperature_c="hot"),
    "meta.temperature_c a list": set_cal(meta__temperature_c=[25]),
    "meta nested objects": set_cal(meta={"temperature_c": {"a": {"b": 1}}, "scale": [K, K, K]}),
    "diagnostics.rms a string": set_cal(diagnostics={"rms": "low"}),
    # row 2: OverflowError from int(inf) in config.check
    "config set rate 1e309": "config set rate 1e309",
    "config set max_cal_s 1e309": "config set max_cal_s 1e309",
    "config set cells 1e309": "config set cells 1e309",
    "config set cells -1e309": "config set cells -1e309",
    "config set rate 400 digits": "config set rate " + str(10 ** 400),
    "config set field_nt Infinity": "config set field_nt Infinity",
    "config set rate NaN": "config set rate NaN",
    "config set field_nt deep": "config set field_nt " + "[" * 1000 + "]" * 1000,
    "set-cal field 400 digits": set_cal(field=grammar.Raw(str(10 ** 400))),
    "set-cal field 1e309": set_cal(field=grammar.Raw("1e309")),
    "set-cal offset NaN": set_cal(offset=[grammar.Raw("NaN"), 0.0, 0.0]),
    "set-cal deep JSON": "set-cal " + '{"a": ' * 600 + "1" + "}" * 600,
    "set-cal deep meta": set_cal(meta=grammar.Raw('{"x": ' + "[" * 900 + "]" * 900 + "}")),
    # found by this fuzzing: MicroPython's bytes.decode accepts overlong forms, UTF-16
    # surrogates and code points past U+10FFFF, and the reply echoed them raw: a line that
    # is not UTF-8, so not JSON, for the laptop
    "overlong UTF-8 command": b"\xc0\xaf\xc0\xaf}",
    "surrogate command": b"\xed\xa0\x80",
    "past U+10FFFF command": b"\xf4\x90\x80\x80 status",
    "surrogate in a config value": b'config set pin_led "\xed\xa0\x80"',
    "overlong in set-cal meta text": set_cal(meta={"firmware": "x", "scale": [K, K, K]}).encode().replace(
        b'"firmware": "x"', b'"firmware": "\xe0\x80\xaf"') + b"\nget-cal",
}


@pytest.mark.parametrize("line", list(PINNED.values()), ids=list(PINNED))
def test_pinned_inputs(harness, line):
    run_case(harness, line if isinstance(line, bytes) else line.encode())


# row 6: records no sensor gives, accepted today; refused with a code, the good one kept
IMPLAUSIBLE = {
    "field 1e-3 nT": set_cal(field=1e-3),
    "field 1e308 nT": set_cal(field=1e308),
    "offset 1e12 codes": set_cal(offset=[1e12, 0.0, 0.0]),
    "axis skewed 89 degrees": set_cal(matrix=[[K, 0.0, 0.0], [K * 0.99985, K * 0.01745, 0.0], [0.0, 0.0, K]]),
    "symmetric skew 89 degrees": set_cal(matrix=[[K, K * 0.99985, 0.0], [K * 0.99985, K, 0.0], [0.0, 0.0, K]]),
}


@pytest.mark.parametrize("line", list(IMPLAUSIBLE.values()), ids=list(IMPLAUSIBLE))
def test_implausible_set_cal_is_refused_and_the_good_one_kept(harness, line):
    assert harness.ask(set_cal())["ok"]
    before = harness.ask("get-cal")["cal"]
    r = harness.ask(line)
    assert r is not None and r["ok"] is False and r["error"] not in ("internal_error",), r
    assert harness.ask("get-cal")["cal"] == before
    run_case(harness, b"status")


def test_config_changes_do_not_trip_an_adc_fault(harness):
    """Found by the fuzzing: a `config set` of any key zeroes the acquisition's counters
    (apply_config -> _setup_pipeline -> set_decimation -> reset) while health.py keeps the
    frame count of its last check; a check that finds the same count again (both counted
    from a reset at the same distance) sees no conversion, and adc_no_drdy ('no conversion
    for 265 ms') stops the survey of a healthy ADC. Config changes at uneven intervals, as
    a user or a script sends them: no fault event, the survey goes on."""
    c = harness.client
    start = len(c.seen)
    for k in range(60):
        r = harness.ask("config set min_coverage 0.5")
        assert r is not None and r["ok"], r
        c.step(0.02 * (1 + k % 13))
    faults = [e for e in c.seen[start:] if e.get("ev") == "fault"]
    assert faults == [], faults
    assert harness.ask("status")["state"] == "survey"
