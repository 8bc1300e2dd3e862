# Runs under each interpreter (tests/test_survey_finish.py): device/survey.py's Survey.finish on
# the C's block sums (fitsums.survey's words, each sum four 16-bit limbs, least significant
# first) as given, with its own Python sums set to argv[4]. argv[1] the repository root,
# argv[2] a JSON file of [[20 limbs], ...]; prints the block finish returns for each, a JSON line.
import json
import sys
from array import array

for folder in (sys.argv[1] + "/device", sys.argv[1]):
    sys.path.insert(0, folder)
from survey import _LEFT, Survey  # noqa: E402

with open(sys.argv[2]) as fh:
    cases = json.load(fh)
python_sums = int(sys.argv[3])
sv = Survey({"survey_hz": 10}, 2, 100, native=False)
for limbs in cases:
    sv.words = array("H", [0] * 86)
    for k in range(20):
        sv.words[k] = limbs[k]
    sv.words[_LEFT] = 0
    sv._sx = sv._sy = sv._sz = sv._st = sv._f = python_sums
    print(json.dumps(list(sv.finish())))
