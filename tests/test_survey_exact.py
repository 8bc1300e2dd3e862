"""The survey output's |B| and h_c on every interpreter against CPython's float64.

The survey corrects in integers (shared/fixedpoint.py): device/survey.py's Output, run on each
interpreter (tests/micropython/survey_exact.py) with the same records and window sums, must
print what CPython's float64 correction gives, rounded to the milli-nT the output carries:
- without temperature coefficients, digit for digit the text CPython's own run of the same
  code prints (nothing in the path depends on the float's width);
- and within 0.0005 nT (the printed milli-nT's rounding) + 3e-5 nT (the integer path's own
  roundings, fixedpoint.py's docstring) of float64's unrounded value, so within 0.001 nT of
  what CPython's float64 output prints;
- with temperature coefficients, the same bound: only the products g tau and o tau are
  floats there, their rounding 2**-22 relative on 30-bit floats (< 1e-6 nT at these
  coefficients).
Calibrations: the realistic instrument's fit, adversarial ones (offsets at the ADC's range,
condition number 2.9, strong cross terms), a record a 30-bit board wrote; sums: a spin,
full-scale codes (+-2**23 in every combination) and random codes over the whole range;
windows of 1, 2 and 64 codes.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from desktop.methods import fit_array
from desktop.sim.instrument import realistic_instrument
from shared.calibration import Calibration
from shared.fixedpoint import ExactCorrection, float_pair, isqrt
from desktop.devicesim.runners import heap_for
from tests.interpreters import INTERPRETERS, need
from tests.test_native_sums import LOADS_NATMODS, _need_natmod

SCRIPT = os.path.join(os.path.dirname(__file__), "micropython", "survey_exact.py")
PICO_CASES = (0, 4, 6)      # realistic; adversarial at window 64; a board's record
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PRINTED_NT = 0.0005          # the output's milli-nT: half of it is the rounding
INTEGER_PATH_NT = 3e-5       # fixedpoint.py: 2.2e-5 from the coefficients + the floors
FULL = 1 << 23               # the ADS1292's full scale, codes [DS 8.3.8]


def _record(matrix, offset, tempco=None):
    return Calibration(matrix, offset, 48000.0, tempco=tempco).to_dict()


def _adversarial(rng, cond):
    """M = R diag(k g) R^T, gains spread to the condition number, a random rotation R; offsets
    near the ADC's full scale with fractional parts."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    k = 0.0144243258 * np.array([1.0, cond ** 0.5, cond])
    m = q @ np.diag(k) @ q.T
    m = (m + m.T) / 2
    off = rng.choice([-1, 1], 3) * rng.uniform(0.9, 0.999, 3) * FULL
    return _record(m.tolist(), off.tolist())


def _board_record(record):
    """The record as a 30-bit-float board writes it: every number rounded to 22 bits."""
    def narrow(x):
        m, e = np.frexp(x)
        return float(np.ldexp(np.round(m * 2.0 ** 22), e - 22))
    cal = Calibration([[narrow(v) for v in row] for row in record["matrix"]],
                      [narrow(v) for v in record["offset"]], 48000.0)
    return cal.to_dict()


def _sums(rng, window, spin):
    corners = [[sx * FULL * window - (sx > 0) * window for sx in c]
               for c in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3)]
    random = rng.integers(-FULL * window, FULL * window, size=(120, 3)).tolist()
    spun = (spin[:200] * window + rng.integers(0, window, size=(200, 3))).tolist()
    return [[int(v) for v in s] for s in corners + random + spun]


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    rng = np.random.default_rng(19)
    fit_codes, spin, field = realistic_instrument()
    real = fit_array(fit_codes.astype(float), field=field).to_dict()
    tempco = {"t0_c": 20.0, "offset_per_c": [3.1, -2.7, 1.3], "gain_per_c": [4.1e-5, -2.3e-5, 3.3e-5],
              "range_c": [5.0, 35.0], "sources": 3, "method": "calibrations"}
    with_tempco = Calibration.from_dict(real)
    with_tempco = _record(with_tempco.matrix, with_tempco.offset, tempco)
    cases = []
    for cal, window, per_block, temp in [(real, 2, 10, None), (real, 1, 7, None), (real, 64, 1, None),
                                         (_adversarial(rng, 2.9), 2, 10, None),
                                         (_adversarial(rng, 2.9), 64, 3, None),
                                         (_adversarial(rng, 1.7), 1, 10, None),
                                         (_board_record(real), 2, 10, None),
                                         (with_tempco, 2, 10, 33.7), (with_tempco, 2, 10, -4.9)]:
        cases.append({"cal": cal, "window": window, "per_block": per_block, "temp": temp,
                      "sums": _sums(rng, window, spin)})
    folder = tmp_path_factory.mktemp("survey-exact")
    paths = []
    for i, case in enumerate(cases):
        paths.append(folder / ("case%d.json" % i))
        paths[-1].write_text(json.dumps(case))
    return paths, cases


def _float64(case):
    """What CPython's float64 correction gives for each block: (h_c, mean |h_c|), nT, unrounded."""
    cal = Calibration.from_dict(case["cal"])
    if case["temp"] is not None:
        cal = cal.at_temperature(case["temp"])
    w, n = case["window"], case["per_block"]
    per_sample = cal.scaled_input(w)
    sums = np.array(case["sums"], dtype=np.int64)
    out = []
    for k in range(len(sums) // n):
        blk = sums[k * n:(k + 1) * n]
        f = sum(per_sample.magnitude(*(int(v) for v in s)) for s in blk) / n
        b = cal.correct(*(float(v) / (n * w) for v in blk.sum(axis=0)))
        out.append((b, f))
    return out


def _run(command, paths, root, natmod=None):
    """Each case's data events' members, from the script run by command (a list); with natmod
    (fitsums.mpy's folder), then "#native" or "#python"."""
    out = []
    for path in paths:
        proc = subprocess.run(command + [SCRIPT, str(path), root] + ([natmod] if natmod else []),
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
        out.append(proc.stdout.splitlines())
    return out


@pytest.fixture(scope="module")
def cpython(job, root):
    return _run([sys.executable], job[0], root)


def _check_against_float64(sent, cases):
    worst = 0.0
    for members, case in zip(sent, cases):
        ref = _float64(case)
        assert len(members) == len(ref)
        for text, (b, f) in zip(members, ref):
            got = json.loads(text)
            for g, r in zip(got["b"] + [got["f"]], list(b) + [f]):
                worst = max(worst, abs(g - r))
                assert abs(g - r) <= PRINTED_NT + INTEGER_PATH_NT, (text, b, f)
                # what float64 prints, to the digit (milli-nT compared as integers)
                assert abs(round(g * 1000) - round(round(r, 3) * 1000)) <= 1
    return worst


def test_cpythons_survey_output_is_float64_to_the_printed_digit(job, cpython):
    path, cases = job
    _check_against_float64(cpython, cases)


@pytest.mark.parametrize("name", INTERPRETERS)
def test_survey_output_is_cpythons_on_every_float_width(name, job, cpython, root):
    path, cases = job
    # in the heap a simulated board of its word size has (desktop/devicesim/runners.py)
    got = _run([need(name), "-X", "heapsize=" + heap_for(name)], path, root)
    for members, ref, case in zip(got, cpython, cases):
        if case["temp"] is None:
            assert members == ref      # the same digits: nothing in the path is a float
    _check_against_float64(got, cases)


@pytest.mark.parametrize("name", sorted(set(INTERPRETERS) & LOADS_NATMODS))
def test_survey_output_in_c_is_the_pure_ones(name, job, cpython, root):
    """With the fitsums.mpy deploy picks for the interpreter (each sample's |h_c| and the block's
    sums in fitsums.survey, the block's h_c in fitsums.correct): the lines of its pure-Python
    run (CPython's where no float enters), and the native path taken."""
    path, cases = job
    exe = need(name)
    natmod = os.path.dirname(_need_natmod(exe, name))
    heap = ["-X", "heapsize=" + heap_for(name)]
    pure = _run([exe] + heap, path, root)
    for members, ref, same, case in zip(_run([exe] + heap, path, root, natmod), cpython, pure, cases):
        assert members[-1] == "#native"
        assert members[:-1] == same
        if case["temp"] is None:
            assert members[:-1] == ref


def test_survey_output_in_c_on_the_emulated_pico(job, cpython, tmp_path):
    """The same on the emulated Pico (armv6m fitsums.mpy, 31-bit small ints): a realistic, an
    adversarial (window 64: its blocks' sums past a small int, correct in Python) and a board's
    record, CPython's lines to the digit. The modules are in the flash's filesystem before it boots
    (tests/pico_flash.py) and each case runs after its own soft reset."""
    need("rp2-pico")
    from desktop.bench.pico_survey import _disk
    from desktop.devicesim.pico_board import PicoBoard
    from tests.pico_flash import flash_with
    path, cases = job
    disk = tmp_path / "disk"
    _disk(str(disk), REPO, cases[0], script=SCRIPT)
    for i in PICO_CASES:
        (disk / ("job%d.json" % i)).write_text(json.dumps(cases[i]))
    mpremote = [sys.executable, "-m", "mpremote", "connect"]
    flash_with(str(tmp_path / "pico.flash"), str(disk))
    with PicoBoard(str(tmp_path / "pico.flash")) as board:
        for i in PICO_CASES:
            run = ("import os, sys; os.rename('/disk/job%d.json', '/disk/job.json'); "
                   "sys.path.insert(0, '/disk'); import pico_survey" % i)
            r = subprocess.run(mpremote + [board.port, "exec", run], capture_output=True, text=True, timeout=600)
            got = r.stdout.splitlines()
            assert r.returncode == 0 and got[-1] == "#native", (i, r.stdout[-400:] + r.stderr)
            assert got[-1 - len(cpython[i]):-1] == cpython[i]


def test_float_pair_is_exact_and_short():
    for x in (0.0, 1.0, -0.0144243258, 3394279.5720390626, 5e-324, 1.7976931348623157e308, -2.0 ** -30):
        m, e = float_pair(x)
        assert m * 2.0 ** e == x if e > -1000 else np.ldexp(float(m), e) == x
        assert m == 0 or m & 1      # no trailing zero bits: a 30-bit board's numbers stay short


def test_isqrt_is_the_floor_of_the_root():
    rng = np.random.default_rng(3)
    for q in [0, 1, 2, 3, 4, 15, 16, 17, (1 << 72) - 1, 1 << 72] + [int(v) << 40 for v in rng.integers(1, 1 << 40, 50)]:
        r = isqrt(q)
        assert r * r <= q < (r + 1) * (r + 1)


def test_a_record_without_exact_numbers_still_loads_and_corrects():
    d = _record([[0.0144, 0.0, 0.0], [0.0, 0.0145, 0.0], [0.0, 0.0, 0.0143]], [100.5, -200.25, 3.0])
    del d["exact"]
    cal = Calibration.from_dict(d)
    f = ExactCorrection(cal, 2).magnitude(2 * 3333333, 2 * 10, -2 * 5) / 256000.0
    assert abs(f - cal.scaled_input(2).magnitude(2 * 3333333, 2 * 10, -2 * 5)) <= INTEGER_PATH_NT


@pytest.mark.parametrize("where, value, why", [
    (("matrix", 0, 0), [1, 0], "is not the record's matrix"), (("offset", 1), [3, "e"], "two integers"),
    (("offset", 2), [1 << 60, 0], "2..53"), (("matrix", 2), [[1, 0]], "3x3")])
def test_exact_numbers_that_disagree_or_are_malformed_are_refused(where, value, why):
    d = _record([[0.0144, 0.0, 0.0], [0.0, 0.0145, 0.0], [0.0, 0.0, 0.0143]], [100.5, -200.25, 3.0])
    node = d["exact"][where[0]]
    for i in where[1:-1]:
        node = node[i]
    node[where[-1]] = value
    with pytest.raises(ValueError, match=why):
        Calibration.from_dict(d)
