"""README.md and docs/*.md held to the code: every name they give must exist.

What the docs name, and where the truth is read from:
- files and folders (`shared/quick.py`, tests/test_cli.py, [links](docs/x.md#anchor)): the tree;
- `fluxcal SUB --option`: the parsers of desktop.cli.build_parser();
- `python -m MODULE --option`, `make TARGET`: the module's add_argument calls, the Makefile;
- protocol commands (`start-cal`, `> status`): device/commands.py TABLE;
- config keys (`config set KEY`, the firmware.md table with defaults, types and ranges):
  device/config.py SCHEMA;
- Python names (`EllipsoidFit.solve`, `shared.coverage.Coverage`, `solve(prior=...)`, a
  ```python block): classes, functions, methods, keyword arguments and identifiers read by ast
  from the repository's code.
Each check has a test that plants a wrong name and sees it fail (test_*_catches_*).

    python tests/test_docs.py config-table    # the config table's key/default/type/range columns
"""

import os
import re
import sys
import pytest

if __name__ == "__main__":   # run as a script (config-table): the repository on the path
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from tests.docs_index import (CODE_DIRS, CodeIndex, ROOT, _rel, doc_files, parse_doc)
from tests.docs_checks import (check_command, check_links, check_paths, check_section_names, check_span, fluxcal_parsers)
from tests.docs_tables import (check_config_table, check_protocol_doc, check_python_block, command_table, config_row, config_schema, config_table_rows)


@pytest.fixture(scope="module")
def index():
    return CodeIndex()


@pytest.fixture(scope="module")
def docs():
    return {_rel(p): parse_doc(p) for p in doc_files()}


# ---------------------------------------------------------------- the tests

def all_problems(docs, index):
    subs, table, schema = fluxcal_parsers(), command_table(), config_schema()
    problems = []
    for doc, (prose, code, spans) in docs.items():
        text = "\n".join(line for _n, line in prose) + "\n" + "\n".join(line for _n, line, _l in code)
        problems += check_paths(doc, text)
        problems += check_links(doc, "\n".join(line for _n, line in prose))
        problems += check_section_names(doc, "\n".join(line for _n, line in prose))
        for n, span in spans:
            problems += ["%s (line %d)" % (p, n) for p in check_span(doc, span, index, subs, table, schema)]
        for n, line, lang in code:
            problems += ["%s (line %d)" % (p, n) for p in check_command(doc, line, subs, index)]
        blocks = {}
        for n, line, lang in code:
            if lang == "python":
                blocks.setdefault(lang, []).append(line)
        if blocks:
            problems += check_python_block(doc, "\n".join(blocks["python"]), index)
        problems += check_protocol_doc(doc, prose, code, table)
    problems += check_config_table(schema, config_table_rows(os.path.join(ROOT, "docs", "firmware.md")))
    return problems


def test_docs_name_only_what_exists(docs, index):
    problems = all_problems(docs, index)
    assert not problems, "%d names in the docs the code lacks:\n" % len(problems) + "\n".join(problems)


def test_docs_give_no_issue_numbers_or_history(docs):
    """Users read the docs: history and issue numbers go to CHANGELOG.md."""
    found = []
    for doc, (prose, code, _spans) in docs.items():
        for n, line in prose:
            if re.search(r"\bissues? \d+", line, re.I):
                found.append("%s:%d: %s" % (doc, n, line.strip()[:100]))
    assert not found, "issue numbers in the docs:\n" + "\n".join(found)


def test_readme_is_short():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        assert len(fh.read().splitlines()) <= 200, "README.md over 200 lines: move detail to docs/"



def code_doc_citations(text):
    return re.findall(r"\b(?:docs/[\w./-]+\.(?:md|png)|README\.md|CHANGELOG\.md)", text)


def test_code_cites_only_docs_that_exist():
    """A comment or docstring that sends the reader to docs/NAME.md: the file is there."""
    missing = []
    for top in CODE_DIRS:
        for folder, dirs, names in os.walk(os.path.join(ROOT, top)):
            for name in names:
                if name.endswith(".py") and not name.startswith(("test_docs", "docs_")):    # the doc checks' own examples
                    path = os.path.join(folder, name)
                    with open(path, encoding="utf-8") as fh:
                        for cited in code_doc_citations(fh.read()):
                            if not os.path.exists(os.path.join(ROOT, cited)):
                                missing.append("%s cites %s" % (_rel(path), cited))
    assert not missing, "\n".join(missing)
    assert code_doc_citations("see docs/experiments.md, lag") == ["docs/experiments.md"]   # what it finds


def firmware_table_files(path):
    """The .py names in the first column of docs/firmware.md's `| file | what |` table."""
    names, in_table = set(), False
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            if line.startswith("| file | what |"):
                in_table = True
            elif in_table and not line.startswith("|"):
                break
            elif in_table:
                first = line.strip().strip("|").split("|")[0]
                names.update(os.path.basename(n) for n in re.findall(r"`([\w/]+\.py)`", first))
    return names


def test_firmware_doc_has_a_row_for_every_firmware_file():
    """docs/firmware.md's module table: one row (or a shared row) per file under device/."""
    files = {n for _d, _s, names in os.walk(os.path.join(ROOT, "device")) for n in names
             if n.endswith(".py") and n != "__init__.py"}
    listed = firmware_table_files(os.path.join(ROOT, "docs", "firmware.md"))
    assert listed == files, "not in the table: %s; not in device/: %s" % (sorted(files - listed), sorted(listed - files))


def test_readme_command_table_lists_every_subcommand():
    """The README's table of commands: one row per `fluxcal` subcommand, none invented."""
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        text = fh.read()
    listed = re.findall(r"^\| `fluxcal ([a-z-]+)", text, re.M)
    assert sorted(listed) == sorted(fluxcal_parsers()), (sorted(listed), sorted(fluxcal_parsers()))


def test_readme_command_table_rows_name_the_required_options():
    """A row of the README's table is a command a user may copy: it names every option its
    subcommand cannot run without (`capture` without `--seconds` is refused by the parser)."""
    from desktop.cli import build_parser
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        rows = dict(re.findall(r"^\| `fluxcal ([a-z-]+)([^`]*)`", fh.read(), re.M))
    parser = build_parser()
    subs = next(a.choices for a in parser._actions if isinstance(getattr(a, "choices", None), dict))
    missing = ["fluxcal %s: %s" % (name, opt) for name, sub in subs.items() for a in sub._actions
               if a.required and a.option_strings for opt in a.option_strings[:1]
               if name in rows and not set(a.option_strings) & set(re.findall(r"--?[\w-]+", rows[name]))]
    assert missing == [], missing


# every check, shown to fail on a planted wrong name (the same functions the doc test runs)

def _planted(index, text, lang="", doc="planted.md"):
    subs, table, schema = fluxcal_parsers(), command_table(), config_schema()
    problems = check_paths(doc, text) + check_links(doc, text) + check_section_names(doc, text)
    for span in re.findall(r"`([^`]+)`", text):
        problems += check_span(doc, span, index, subs, table, schema)
    if lang == "python":
        problems += check_python_block(doc, text, index)
    return problems


@pytest.mark.parametrize("right, wrong", [
    ("`shared/quick.py`", "`shared/quik.py`"),
    ("see tests/test_cli.py", "see tests/test_clii.py"),
    ("`app.py`", "`apps.py`"),
    ("[x](docs/protocol.md#status)", "[x](docs/protocol.md#statuses)"),
    ("[x](docs/protocol.md)", "[x](docs/experiments.md)"),
    ('docs/simulator.md, "Sensor lag"', 'docs/simulator.md, "Sensor drag"'),
    ('(README, "Layout")', '(README, "The command line")'),
    ("`docs/firmware.md`", "`../shared/reference/ads1292-and-runtimes.md`"),
    ("`fluxcal fit --prior OLD.json`", "`fluxcal fit --priors OLD.json`"),
    ("`fluxcal calibrate --quick`", "`fluxcal calibrat --quick`"),
    ("`fluxcal fit RAW --method streaming|mle`", "`fluxcal fit RAW --method streaming|lsq`"),
    ("`fluxcal experiment lag -o DIR`", "`fluxcal experiment drag -o DIR`"),
    ("`fluxcal emulate --runtime micropython-reprc`", "`fluxcal emulate --runtime micropython-repr`"),
    ("`python -m desktop.bench.cortexm --before e405f90`", "`python -m desktop.bench.cortexm --after e405f90`"),
    ("`python -m desktop.bench.fuzz`", "`python -m desktop.bench.fuzzer`"),
    ("`make demo`", "`make demos`"),
    ("`--accept-anyway`", "`--accept-always`"),
    ("`start-cal`", "`begin-cal`"),
    ("`config set survey_hz 10`", "`config set survey_rate 10`"),
    ("`EllipsoidFit.solve`", "`EllipsoidFit.solver`"),
    ("`shared.coverage.Coverage`", "`shared.coverage.Coverages`"),
    ("`WarmupFit`", "`WarmUpFit`"),
    ("`fit_tempco`", "`fit_temp_co`"),
    ("`not_better`", "`not_improved`"),
    ("`commands.status`", "`commands.cmd_status`"),
    ("`rej_*`", "`cmd_*`"),
    ("`solve(prior=previous)`", "`solve(prior_cal=previous)`"),
])
def test_each_check_catches_a_planted_wrong_name(index, right, wrong):
    assert not _planted(index, right), _planted(index, right)
    assert _planted(index, wrong), "%s passed" % wrong


def test_firmware_doc_check_catches_a_bare_name_from_elsewhere(index):
    """In docs/firmware.md `app.py` is the firmware's; `emulate.py` (desktop/cli/) needs its path."""
    assert not _planted(index, "`app.py`, desktop/cli/emulate.py", doc="docs/firmware.md")
    assert _planted(index, "`emulate.py`", doc="docs/firmware.md")
    assert not _planted(index, "`emulate.py`", doc="docs/cli.md")


def test_python_block_check_catches_a_changed_signature(index):
    good = "from shared.fit import EllipsoidFit\nfit = EllipsoidFit()\ncal = fit.solve(field=None, scale=1.0)\n"
    assert not _planted(index, good, "python")
    assert _planted(index, good.replace("scale=", "units="), "python")
    assert _planted(index, good.replace("EllipsoidFit\n", "EllipsoidFitter\n", 1), "python")


def test_protocol_check_catches_a_missing_or_invented_command():
    table = command_table()
    rows = [(0, "| command | reply | errors |")] + [(1, "| `%s` | x | y |" % c) for c in table]
    assert not check_protocol_doc("docs/protocol.md", rows, [], table)
    assert check_protocol_doc("docs/protocol.md", rows[:1] + rows[2:], [], table)          # one missing
    assert check_protocol_doc("docs/protocol.md", rows + [(9, "| `reboot` | x | y |")], [], table)
    assert check_protocol_doc("x.md", [], [(1, "> reboot", ""), (2, "{}", "")], table)


def test_config_check_catches_a_wrong_default_range_or_key():
    schema = config_schema()
    rows = {k: config_row(k, e) for k, e in schema.items()}
    assert not check_config_table(schema, rows)
    for key, bad in (("rate", ("`rate`", "2000", "int", "125 – 8000")),
                     ("decim", ("`decim`", "10", "int", "1 – 255")),
                     ("log", ("`log`", "false", "int", "-"))):
        assert check_config_table(schema, dict(rows, **{key: bad}))
    assert check_config_table(schema, dict(rows, survey_rate=rows["survey_hz"]))
    del rows["survey_hz"]
    assert check_config_table(schema, rows)


if __name__ == "__main__":
    if sys.argv[1:] == ["config-table"]:
        for key, entry in config_schema().items():
            print("| %s |  |" % " | ".join(config_row(key, entry)))
    else:
        print(__doc__)


def test_protocol_failure_table_lists_every_calibration_refusal():
    """docs/protocol.md's "Calibration failure reasons": a row for each refusal shared/codes.py
    declares (its block from "calibration refusals" to the acceptance threshold), so a reason a
    `cal` event can carry is never one the operator's manual leaves out."""
    with open(os.path.join(ROOT, "shared", "codes.py"), encoding="utf-8") as fh:
        block = fh.read().split("calibration refusals", 1)[1].split("MAX_PREDICTED_NT", 1)[0]
    reasons = set(re.findall(r'^[A-Z_]+ = "([a-z_]+)"', block, re.M))
    with open(os.path.join(ROOT, "docs", "protocol.md"), encoding="utf-8") as fh:
        table = fh.read().split("## Calibration failure reasons", 1)[1].split("\n## ", 1)[0]
    rows = set(re.findall(r"^\| `([a-z_]+)`", table, re.M)) | set(re.findall(r"^\| `[a-z_]+`, `([a-z_]+)`", table, re.M))
    assert len(reasons) > 10 and reasons - rows == set(), sorted(reasons - rows)
