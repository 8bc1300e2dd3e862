# Runs under CPython (the pure-Python reader and output: the reference) and each MicroPython board:
# the DRDY ring's reader and the survey output's sample, Acquisition.poll into Output.sample, in C
# where drdy.mpy loads (drdy.Drain, drdy.Sample) against native=False (the Python methods) on the
# same interpreter, the same samples in the same ring. From argv (the case file, the repository
# root, the natmods' folder or "") or, imported on a board, /disk/job.json and /disk. The case: a
# calibration record and window sums of a spin with their block numbers, in scenarios: the
# corrected stream de-lagged, the same with flipped bits, clipped samples and gaps of one and more
# blocks, the raw stream, a calibration in progress (a stand-in session), no stream. Prints each
# scenario's outcome as a JSON line (the events' texts, the session's samples, the counters), then
# one line: the path taken (status's `reader` and `sample` must say it) and how many scenarios the
# two paths differed in.
import json
import sys


class Session:
    """A calibration in progress as Output sees it: the samples, clipped ones, temperatures, breaks."""
    taus_us = None
    steps_us = None

    def __init__(self):
        self.got = []
        self.clipped = 0
        self.clip_axis = None
        self.breaks = 0

    def sample(self, x, y, z):
        self.got.append((x, y, z))

    def add_temperature(self, c):
        self.got.append(c)

    def break_chain(self):
        self.breaks += 1

    def attach(self, delag):
        pass


def run(case, scenario, native):
    from acquisition import SLOTS, Acquisition
    from config import defaults
    from shared.calibration import Calibration
    from survey import Output
    from survey_stand_ins import Board, Die, Line
    cfg = defaults()
    cfg["log"] = False
    texts = []
    o = Output(Board(), Line(lambda line: texts.append(bytes(line).decode())), native=native)
    o.adc = Die(25.0)
    o.configure(cfg, cfg["rate"] / cfg["decim"])
    cal = Calibration.from_dict(case["cal"])
    if scenario["delag"]:
        cal.response = {"tau_s": [scenario["delag"]] * 3}
    o.use(cal)
    s = None
    if scenario["session"]:
        s = o.session = Session()
        o.respond()
    o.set_stream(scenario["stream"])
    acq = o.acq = Acquisition(Board(), cfg["decim"], cfg["window"], native=native)
    ring, st = acq.ring, acq.state
    rows = scenario["rows"]
    limits = (1, 2, 3, 16)
    k = 0
    polls = 0
    while k < len(rows):
        for r in rows[k:k + 40]:
            j = st[0] * SLOTS
            for i in range(5):
                ring[j + i] = r[i]
            st[0] = (st[0] + 1) % acq.ring_frames
        k += 40
        while acq.poll(o.sample, limits[polls % 4], o.gap):
            polls += 1
        polls += 1
    sc = o.screen
    # what ran (C where the instance's attribute hides the method) and what status says ran: one
    # word where they agree, both pairs where status tells another path than the one taken
    ran = ["native" if "poll" in acq.__dict__ else "python", "native" if "sample" in o.__dict__ else "python"]
    said = [acq.status()["reader"], o.status()["sample"]]
    path = ran[0] if ran == said and ran[0] == ran[1] else "ran %s, status %s" % (ran, said)
    # a list, not a dict: its order is the same on every interpreter
    return path, [texts, None if s is None else [s.got, s.clipped, s.clip_axis, s.breaks],
                  [acq.samples, acq.gaps, acq.last_block, acq.available()],
                  [sc.spikes, sc.clipped, sc.clip_axis], o.delag.saturated, o.survey.blocks]


def main(root, natmod, case_path="/disk/job.json"):
    for folder in (root + "/device", root + "/desktop/bench/micropython-scripts", root, natmod):
        if folder and folder not in sys.path:
            sys.path.insert(0, folder)
    with open(case_path) as fh:
        case = json.load(fh)
    differed = 0
    paths = []
    for scenario in case["scenarios"]:
        path, a = run(case, scenario, True)
        python, b = run(case, scenario, False)
        paths.append(path)
        assert python == "python"
        if a != b:
            differed += 1
        print(json.dumps(b))
    print(json.dumps({"paths": paths, "differed": differed}))


if len(sys.argv) > 3:
    main(sys.argv[2], sys.argv[3], sys.argv[1])
else:               # imported on a board (desktop/bench/pico_survey.py's disk)
    main("/disk", "/disk")
