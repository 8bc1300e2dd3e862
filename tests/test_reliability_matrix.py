"""docs/reliability.md and the suite cannot drift apart: every test the matrix names exists,
every row has a status, and the tally line (and the README's row) counts them."""

import ast
import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "reliability.md")


def rows():
    """(status, [test ids]) of every matrix row."""
    out = []
    for line in open(DOC).read().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 4 and cells[2] in ("held", "fixed", "open"):
            out.append((cells[2], re.findall(r"`(tests/[\w/]+\.py::\w+)`", cells[3])))
    return out


def test_every_row_names_a_test_that_exists():
    found = rows()
    assert len(found) > 30
    defined = {}
    for status, ids in found:
        assert ids, "a row without a test"
        for tid in ids:
            path, name = tid.split("::")
            if path not in defined:
                tree = ast.parse(open(os.path.join(ROOT, path)).read())
                defined[path] = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
            assert name in defined[path], "%s names %s, which does not exist" % (DOC, tid)


def test_the_tally_counts_the_rows():
    found = rows()
    n = {s: sum(1 for st, _ in found if st == s) for s in ("held", "fixed", "open")}
    want = "Tally: %d held, %d fixed, %d open." % (n["held"], n["fixed"], n["open"])
    assert want in open(DOC).read(), want
    # the README's results row quotes the same tally
    readme = open(os.path.join(ROOT, "README.md")).read()
    quoted = "**%d held, %d fixed, %d open**" % (n["held"], n["fixed"], n["open"])
    assert quoted in readme, "README.md's fault-matrix row should read %s" % quoted
