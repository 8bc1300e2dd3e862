"""device/survey.py's block: Survey.finish reads the C's block sums (fitsums.survey's words: five 64-bit
two's complements of four 16-bit limbs, least significant first) in one struct unpacking ("<5q"):
it must give the integer the general formula gives at and across every edge (a small int's,
2**46, the 64-bit ends), on CPython and on every interpreter."""

import json
import os
import subprocess
from array import array

import pytest

from desktop.firmware.files import import_device
from tests.interpreters import INTERPRETERS, need

survey = import_device("survey")
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _limbs(v):
    u = v & ((1 << 64) - 1)
    return [(u >> (16 * k)) & 0xFFFF for k in range(4)]


EDGES = [0, 1, -1, (1 << 30) - 1, 1 << 30, -(1 << 30), -(1 << 30) - 1, (1 << 46) - 1, 1 << 46, -(1 << 46),
         (1 << 63) - 1, -(1 << 63), 0x3FFF0000, 0x3FFFFFFF, -0x40000000, 0xC0000000 - (1 << 32), 0xFFFF, -0x10000,
         (0x3FFF << 32) | 0xFFFFFFFF, 0x4000 << 32, 171798691840, -171798691840]


def _blocks():
    """The edges five at a time (every one in each place over the blocks)."""
    return [(EDGES[k:k + 5] + EDGES[:5])[:5] for k in range(len(EDGES))]


@pytest.mark.parametrize("python_sums", [0, 5, -(1 << 40)])
def test_finish_reads_every_64_bit_sum_as_the_formula_does(python_sums):
    cfg = {"survey_hz": 10}
    sv = survey.Survey(cfg, 2, 100, native=False)
    for values in _blocks():
        sv.words = array("H", [0] * 86)
        for i, v in enumerate(values):
            sv.words[4 * i:4 * i + 4] = array("H", _limbs(v))
        sv.words[survey._LEFT] = 0
        sv._sx = sv._sy = sv._sz = sv._st = sv._f = python_sums
        got = sv.finish()
        assert got == tuple(v + python_sums for v in values) + (sv.per_block,), values


@pytest.mark.parametrize("name", INTERPRETERS)
def test_finish_reads_them_so_on_every_interpreter(name, tmp_path):
    """The same unpacking (struct's "<5q", in C) where it runs: the MicroPython boards that load
    fitsums (CircuitPython's too: the same interpreter's struct), 31- and 63-bit small ints."""
    cases = tmp_path / "limbs.json"
    cases.write_text(json.dumps([sum((_limbs(v) for v in values), []) for values in _blocks()]))
    for python_sums in (0, -(1 << 40)):
        proc = subprocess.run([need(name), os.path.join(REPO, "tests", "micropython", "survey_finish.py"), REPO,
                               str(cases), str(python_sums)], capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr[-2000:]
        got = [json.loads(line) for line in proc.stdout.splitlines()]
        assert got == [[v + python_sums for v in values] + [10] for values in _blocks()]


@pytest.mark.parametrize("stream", ["corrected", "raw"])
def test_a_die_temperature_not_a_number_goes_out_as_null(stream):
    """The block's format with its temperature's "%.2f" as "%s" of null (survey.py makes it only
    then): the event is JSON, its other numbers as in a block with a temperature."""
    import sys
    sys.path.insert(0, os.path.join(REPO, "desktop", "bench", "micropython-scripts"))
    from survey_stand_ins import Board, Die, Line
    from shared.calibration import Calibration
    config = import_device("config")
    texts = {}
    for temp in (25.0, float("nan")):
        cfg = config.defaults()
        cfg["log"] = False
        got = texts[temp == temp] = []
        o = survey.Output(Board(), Line(lambda line: got.append(line.decode())), native=False)
        o.adc = Die(temp)
        o.configure(cfg, 100)
        o.use(Calibration([[0.0144, 0, 0], [0, 0.0145, 0], [0, 0, 0.0143]], [100.0, -200.0, 50.0], 48000.0))
        o.set_stream(stream)
        for i in range(30):
            o.sample(2000000 + 1000 * i, -1500000, 2500000 - 700 * i, 9000)
    assert len(texts[True]) == len(texts[False]) >= 2
    for good, bad in zip(texts[True], texts[False]):
        g, b = json.loads(good), json.loads(bad)
        assert g["temp"] == 25.0 and b["temp"] is None
        g.pop("temp"), b.pop("temp")
        assert g == b


# a block's lines as main's survey.py made them before they were bytes (Protocol.event's framing
# of one str format; the log's str line): the same bytes now, to the byte
DATA_LINE = (b'{"v": 1, "ev": "data", "t": 0, "temp": -3.46, "c": [555500.00, -749961.50, 1246150.00], "cal": true, '
             b'"warn": "temperature -3.5 C differs from calibration 20.0 C", "b": [7922.784, -10871.542, 17819.230], '
             b'"f": 24374.239}\n')
LOG_FILE = b't_ms,x_nt,y_nt,z_nt,f_nt,temp_c\n0,7922.784,-10871.542,17819.230,24374.239,-3.46\n'
RAW_LINE = b'{"v": 1, "ev": "raw", "t": 0, "n": -1, "c": [555500.00, -749961.50, 1246150.00], "temp": -3.46}\n'


@pytest.mark.parametrize("stream", ["corrected", "raw"])
def test_a_blocks_lines_are_the_protocols_to_the_byte(stream, tmp_path):
    import sys
    sys.path.insert(0, os.path.join(REPO, "desktop", "bench", "micropython-scripts"))
    from survey_stand_ins import Board, Die
    from shared.calibration import Calibration
    config = import_device("config")
    protocol = import_device("protocol")

    class Port(Board):
        root = str(tmp_path)
        sent = []

        def serial_write(self, data):
            self.sent.append(bytes(data))

    cfg = config.defaults()
    cfg["log"] = stream == "corrected"
    board = Port()
    o = survey.Output(board, protocol.Protocol(board, {}, None), native=False)
    o.adc = Die(-3.456)
    o.configure(cfg, 100)
    cal = Calibration([[0.0144, 0.0001, 0], [0, 0.0145, 0], [0, 0, 0.0143]], [100.0, -200.0, 50.0], 48000.0)
    cal.meta["temperature_c"] = 20.0
    o.use(cal)
    o.set_stream(stream)
    for i in range(30):
        o.sample(2000000 + 1000 * i - 3000000 * (i % 3 == 0), -1500000 + 7 * i,
                 2500000 - 700 * i - 5000000 * (i % 2), 9000)
    o.close()
    assert board.sent[0] == (DATA_LINE if stream == "corrected" else RAW_LINE)
    if stream == "corrected":
        assert (tmp_path / "log0.csv").read_bytes() == LOG_FILE
