"""Fuzz the firmware's command parser on the real `micropython` over a pseudo-terminal.

    python -m desktop.bench.fuzz --cases 20000             # prints a tally, then every failure
    python -m desktop.bench.fuzz --cases 500 --seed 7 --kind micropython-float32

Cases come from the grammar (fuzz_grammar.py: commands with generated arguments,
set-cal records mutated field by field, config keys with generated values, random
bytes, long lines, floods) drawn from random.Random; the harness (fuzz_harness.py)
sends each to one firmware on a pty and checks what the protocol owes
(docs/protocol.md): one reply per request line, nothing but JSON, the firmware alive,
the survey streaming after an accepted set-cal. tests/test_protocol_fuzz.py drives the
same cases from hypothesis; this script runs long and tallies.
Not a benchmark: the tally is the output.
"""

import argparse
import collections
import json
import sys
import tempfile
import time

from desktop.bench.fuzz_grammar import RandomDraw, case
from desktop.bench.fuzz_harness import Harness


def failure_kinds(failures):
    """[(kind, [(input, problems), ...])], most frequent first; a kind is a problem's
    text before its first colon, numbers left out."""
    groups = collections.OrderedDict()
    for data, problems in failures:
        for p in problems:
            kind = "".join("N" if ch.isdigit() else ch for ch in p.split(":")[0].split(";")[0]).strip()
            groups.setdefault(kind, []).append((data, problems))
    return sorted(groups.items(), key=lambda kv: -len(kv[1]))


def run(cases, seed=1, kind="micropython", flood_max=200, progress=True, root=None):
    """Run `cases` random cases; (tally Counter, failures [(input, problems)])."""
    draw = RandomDraw(seed)
    with tempfile.TemporaryDirectory(dir=root) as tmp:
        h = Harness(tmp, kind=kind, seed=seed)
        t0 = time.monotonic()
        try:
            for i in range(cases):
                h.check(case(draw, flood_max=flood_max))
                if progress and (i + 1) % 100 == 0:
                    sys.stderr.write("%d cases, %d failed, %.0f s\n" % (i + 1, h.tally["failed cases"],
                                                                       time.monotonic() - t0))
        finally:
            h.close()
        h.tally["boots"] = h.boots
        h.tally["wall s"] = int(time.monotonic() - t0)
    return h.tally, h.failures


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m desktop.bench.fuzz", description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", type=int, default=2000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--kind", default="micropython", help="micropython (default), micropython-float32, "
                   "micropython-reprc, circuitpython, or cpython (in-process)")
    p.add_argument("--flood-max", type=int, default=200, help="lines in the largest flood")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--save", help="write every failing input (exact bytes, as latin-1 text) to this JSON file")
    a = p.parse_args(argv)
    tally, failures = run(a.cases, a.seed, a.kind, a.flood_max, progress=not a.quiet)
    print("fuzz: %d cases on %s, seed %d" % (a.cases, a.kind, a.seed))
    width = max(len(k) for k in tally)
    for k in sorted(tally, key=lambda k: (not k.startswith(("cases", "lines", "failed", "died", "hung")), k)):
        print("  %-*s %8d" % (width, k, tally[k]))
    for kind, cases in failure_kinds(failures):
        print("FAIL x%d: %s" % (len(cases), kind))
        for data, problems in cases[:2]:
            print("  input %r" % (data if len(data) < 300 else data[:300] + b"...",))
            for p in problems:
                print("    " + p[:300])
    if a.save:
        with open(a.save, "w") as f:
            json.dump([{"input": d.decode("latin-1"), "problems": p} for d, p in failures], f, indent=1)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
