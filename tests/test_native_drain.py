"""The DRDY ring's reader and the survey output's sample in C (drdy.Drain and drdy.Sample,
device/native/drdy.c) against the pure-Python Acquisition.poll and Output.sample, bit for bit.

tests/micropython/drain_same.py fills an Acquisition's ring with the window sums of a spin and
their block numbers and polls it (1, 2, 3 and 16 samples a poll) into an Output, once with the
native reader and sample and once with native=False, on each interpreter with the drdy.mpy deploy
would pick for it (and the screen's, the de-lag's and fitsums.mpy beside it), and on the
emulated Pico (armv6m): the corrected stream de-lagged, the same with flipped bits (spikes),
clipped samples and gaps of one block (bridged) and of five, the raw stream, a calibration in
progress (a stand-in session: its samples, clipped count and breaks), no stream. Every event's
text, the session's samples, the reader's and the screen's counters must be the same on both
paths, and as CPython's pure-Python run prints them (the Pico runs the first 120 samples of each,
against CPython's run of those); the native path must be the one taken where the module loads,
and status's `reader` and `sample` must say which ran.
CircuitPython loads no MicroPython .mpy and keeps the Python.
"""

import json
import os
import sys

import numpy as np
import pytest

from desktop.methods import fit_array
from desktop.sim.instrument import realistic_instrument
from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod, output

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(REPO, "tests", "micropython", "drain_same.py")
CLIP = (1 << 23) - (1 << 16)        # screen.py's CLIP_CODES


def _rows(spin, rng, defects, n=300, window=2):
    sums = spin[:n] * window + rng.integers(0, window, size=(n, 3))
    rows = [[int(v) for v in s] + [int(rng.integers(9000, 9100)), 0] for s in sums]
    blk = 0
    for i, r in enumerate(rows):
        if defects and i % 37 == 11:
            r[i % 3] += int(rng.choice([-1, 1])) << int(rng.integers(8, 20))     # a flipped bit
        if defects and i == 150:
            r[1] = CLIP * window + 3                                             # clipped
        if defects and i % 53 == 29:
            blk += 1                          # one block lost: the screen and de-lag bridge it
        if defects and i == 200:
            blk += 5
        r[4] = blk
        blk += 1
    return rows


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    rng = np.random.default_rng(7)
    fit_codes, spin, field = realistic_instrument()
    cal = fit_array(fit_codes.astype(float), field=field).to_dict()
    tau = 0.000725       # the configured response's tau at the defaults (shared/delag.py)
    scenarios = [{"stream": "corrected", "delag": tau, "session": False, "rows": _rows(spin, rng, False)},
                 {"stream": "corrected", "delag": tau, "session": False, "rows": _rows(spin, rng, True)},
                 {"stream": "raw", "delag": tau, "session": False, "rows": _rows(spin, rng, True)},
                 {"stream": "corrected", "delag": tau, "session": True, "rows": _rows(spin, rng, True)},
                 {"stream": "off", "delag": None, "session": False, "rows": _rows(spin, rng, True)}]
    case = {"cal": cal, "scenarios": scenarios}
    # the emulated Pico's heap holds the first 120 samples of each (the defects from 11 on)
    short = {"cal": cal, "scenarios": [dict(sc, rows=sc["rows"][:120]) for sc in scenarios]}
    folder = tmp_path_factory.mktemp("drain")
    (folder / "case.json").write_text(json.dumps(case))
    (folder / "short.json").write_text(json.dumps(short))
    return str(folder / "case.json"), case, str(folder / "short.json"), short


def _check(text, reference, native):
    lines = text.splitlines()
    got = json.loads(lines[-1])
    assert lines[-1 - len(reference):-1] == reference       # every scenario as CPython's Python runs it
    assert got["differed"] == 0                              # the two paths on the interpreter itself
    assert got["paths"] == ["native" if native else "python"] * len(reference)


def _reference(path):
    lines = output([sys.executable, SCRIPT, path, REPO, ""]).splitlines()
    assert json.loads(lines[-1]) == {"paths": ["python"] * 5, "differed": 0}
    return lines[:-1]


@pytest.fixture(scope="module")
def reference(job):
    lines = _reference(job[0])
    scenarios = [json.loads(ln) for ln in lines]
    # the scenarios did what they are for: blocks out, spikes and a clipped sample screened,
    # gaps seen, the session fed, the raw stream sent
    texts, session, acq, screen, _saturated, blocks = zip(*scenarios)
    assert min(blocks) >= 25
    assert screen[1][0] >= 3 and screen[1][1] == 1 and acq[1][1] == 7
    assert len(session[3][0]) > 250 and session[3][1] == 1
    assert '"n": ' in texts[2][0] and texts[4] == []
    return lines


@pytest.mark.parametrize("name", INTERPRETERS)
def test_native_reader_and_sample_are_the_pure_python_ones(name, job, reference, micropython):
    exe = micropython if name == "micropython" else need(name)
    natmod = _need_natmod(exe, name, "drdy")
    _check(output([exe, SCRIPT, job[0], REPO, os.path.dirname(natmod)]), reference, name in LOADS_NATMODS)


def test_native_reader_and_sample_on_the_emulated_pico(job):
    need("rp2-pico")
    from desktop.bench.pico_survey import _disk, run_on_pico
    reference = _reference(job[2])
    got = run_on_pico(lambda disk: _disk(disk, REPO, job[3], script=SCRIPT), "pico_survey", lines=True)
    assert got is not None
    _check("\n".join(got), reference, True)
