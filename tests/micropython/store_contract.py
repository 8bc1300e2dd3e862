# The records store_faults.py saves and loads, and `Row`: its tally of cases and the
# store's contract checked on a fresh boot's load (check_load). Runs under each interpreter.
import json

from faulty_flash import ROOT, mounted


K = 0.0144243258


def record(i):
    """A calibration a sensor can have, a different one for each i."""
    e = 0.001 * i
    return {"version": 1,
            "matrix": [[K * (1 + e), K * e / 10, 0.0], [K * e / 10, K, 0.0], [0.0, 0.0, K * (1 - e)]],
            "offset": [120.5 + i, -230.25, 57.0 * i], "field": 48000.0 + i,
            "diagnostics": {"n": 1400 + i, "rms": 0.18, "observability": 0.66, "predicted_error": 0.02,
                            "iterations": 6},
            "meta": {"temperature_c": 24.5 + i, "firmware": "0.1.0", "uptime_ms": 1000 * i, "rate": 1000,
                     "scale": [K, K, K]}}


def as_read(body):
    """body as a load gives it back: a single-precision float's repr need not read back to
    the same float, so the records compared are the ones json reads (its fixed point)."""
    for _ in range(5):
        again = json.loads(json.dumps(body))
        if again == body:
            break
        body = again
    return body


OLD, NEW, OLDER = as_read(record(1)), as_read(record(2)), as_read(record(0))


def validate(body):
    from shared.calibration import Calibration
    Calibration.from_dict(body)


def stored(store, body):
    """The bytes store.py writes for body (its file format)."""
    return store.encode(body).encode()


class Row:
    def __init__(self, name):
        self.name = name
        self.cases = 0
        self.failures = []

    def case(self):
        self.cases += 1

    def fail(self, label, what):
        if len(self.failures) < 40:
            self.failures.append("%s: %s" % (label, what))

    def check_load(self, label, files, allowed, must_name=()):
        """A fresh load of `files`: the body must be one of `allowed` (None allowed only if
        listed); `problem` must name every file in must_name. Returns (body, source, problem)."""
        _, store = mounted(files)
        try:
            body, src, problem = store.load(ROOT, "cal", validate)
        except BaseException as e:  # noqa: BLE001 - a load that raises is a failure of the row
            self.fail(label, "load raised %r" % (e,))
            return None, None, None
        if not any(body == a for a in allowed):
            self.fail(label, "load gave %s from %s (problem %r), allowed %s"
                      % ("a record" if body is not None else "None", src, problem,
                         [("OLDER" if a is OLDER else "OLD" if a is OLD else "NEW" if a is NEW else a)
                          for a in allowed]))
        for n in must_name:
            if problem is None or n not in problem:
                self.fail(label, "problem %r does not name %s" % (problem, n))
        return body, src, problem
