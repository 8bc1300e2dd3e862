"""device/survey.py Survey.finish reads the C's block sums (fitsums.survey's words: five 64-bit
two's complements of four 16-bit limbs, least significant first) without big integers where
they fit a small int (x, y, z, t) or lie under 2**46 (|h_c|'s sum): each way must give the
integer the general formula gives, at and across every edge between the ways."""

from array import array

import pytest

from desktop.firmware.files import import_device

survey = import_device("survey")


def _limbs(v):
    u = v & ((1 << 64) - 1)
    return [(u >> (16 * k)) & 0xFFFF for k in range(4)]


EDGES = [0, 1, -1, (1 << 30) - 1, 1 << 30, -(1 << 30), -(1 << 30) - 1, (1 << 46) - 1, 1 << 46, -(1 << 46),
         (1 << 63) - 1, -(1 << 63), 0x3FFF0000, 0x3FFFFFFF, -0x40000000, 0xC0000000 - (1 << 32), 0xFFFF, -0x10000,
         (0x3FFF << 32) | 0xFFFFFFFF, 0x4000 << 32, 171798691840, -171798691840]


@pytest.mark.parametrize("python_sums", [0, 5, -(1 << 40)])
def test_finish_reads_every_64_bit_sum_as_the_formula_does(python_sums):
    cfg = {"survey_hz": 10}
    sv = survey.Survey(cfg, 2, 100, native=False)
    for k in range(0, len(EDGES), 5):
        values = (EDGES[k:k + 5] + EDGES[:5])[:5]
        sv.words = array("H", [0] * 86)
        for i, v in enumerate(values):
            sv.words[4 * i:4 * i + 4] = array("H", _limbs(v))
        sv.words[survey._LEFT] = 0
        sv._sx = sv._sy = sv._sz = sv._st = sv._f = python_sums
        got = sv.finish()
        assert got == tuple(v + python_sums for v in values) + (sv.per_block,), values
