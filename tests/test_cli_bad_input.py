"""`fluxcal fit` and `fluxcal correct` on readings no magnetometer gives (issue 10): one
line on stderr, exit 1, nothing written; numpy's overflow warnings never reach the user."""

import math

import pytest

from tests.test_cli import fluxcal


def readings(tmp_path, value=None, row=15, rows=40):
    """A CSV of a plausible rotation (a spiral over a 48,000 nT sphere with an offset),
    data row `row` (1-based) holding `value` as its x when given."""
    lines = ["x,y,z"]
    for i in range(rows):
        z = 1 - (2 * i + 1) / rows
        r = (1 - z * z) ** 0.5
        a = i * 2.399963   # the golden angle
        lines.append("%.3f,%.3f,%.3f" % (48000 * r * math.cos(a) + 150, 48000 * r * math.sin(a) - 80, 48000 * z + 20))
    if value is not None:
        lines[row] = ",".join([value] + lines[row].split(",")[1:])
    path = tmp_path / ("raw.csv" if value is None else "bad.csv")
    path.write_text("\n".join(lines) + "\n")
    return str(path)


@pytest.mark.parametrize("value", ["1e300", "-1e300", "1.7e308", "1e12"])
@pytest.mark.parametrize("method", ["streaming", "algebraic"])
def test_fit_on_a_huge_value_is_one_line_and_exit_1(tmp_path, value, method):
    proc = fluxcal("fit", readings(tmp_path, value), "-o", str(tmp_path / "cal.json"), "--method", method)
    assert proc.returncode == 1
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("fluxcal: "), proc.stderr
    assert "row 15" in proc.stderr and "beyond any magnetometer's range" in proc.stderr
    assert "Warning" not in proc.stderr and "Traceback" not in proc.stderr
    assert proc.stdout == ""
    assert not (tmp_path / "cal.json").exists()


def test_correct_on_a_huge_value_is_one_line_and_exit_1(tmp_path):
    good = readings(tmp_path)
    cal = tmp_path / "cal.json"
    assert fluxcal("fit", good, "-o", str(cal), "--method", "algebraic").returncode == 0
    proc = fluxcal("correct", str(cal), readings(tmp_path, "1e300"), "-o", str(tmp_path / "out.csv"))
    assert proc.returncode == 1
    assert proc.stderr.count("\n") == 1 and "beyond any magnetometer's range" in proc.stderr, proc.stderr
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.parametrize("args, fragment", [
    (["fit", "RAW", "--unit", "furlong", "-o", "OUT"], "argument --unit: invalid choice: 'furlong'"),
    (["fit", "RAW"], "the following arguments are required: -o/--output"),
    (["no-such-command"], "invalid choice: 'no-such-command'"),
    (["report", "RAW", "--cal"], "argument --cal: expected one argument"),
])
def test_a_bad_option_is_one_line_exit_1_and_names_the_help(tmp_path, args, fragment):
    # the README's and docs/cli.md's rule holds for argparse's refusals too: not its usage block and exit 2
    args = [readings(tmp_path) if a == "RAW" else str(tmp_path / "cal.json") if a == "OUT" else a for a in args]
    proc = fluxcal(*args)
    assert proc.returncode == 1
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("fluxcal: "), proc.stderr
    assert fragment in proc.stderr and "--help)" in proc.stderr
    assert not (tmp_path / "cal.json").exists()


@pytest.mark.parametrize("unit", ["G", "gauss", "Gauss", "g"])
def test_a_log_in_gauss_is_read_under_any_of_its_spellings(tmp_path, unit):
    gauss = tmp_path / "gauss.csv"
    rows = open(readings(tmp_path)).read().splitlines()
    gauss.write_text("\n".join([rows[0]] + [",".join("%.8f" % (float(v) / 1e5) for v in r.split(",")) for r in rows[1:]]) + "\n")
    proc = fluxcal("fit", str(gauss), "--unit", unit, "-o", str(tmp_path / "cal.json"))
    assert proc.returncode == 0, proc.stderr
    assert "field 48000" in proc.stdout
