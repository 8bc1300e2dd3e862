"""Magnetometer logs as loggers write them (desktop/formats/logtext.py, readings.py): any common
layout and unit reads to the same nT, and every problem is one line saying what to pass."""

import numpy as np
import pytest

from desktop.cli import main
from desktop.formats import FormatError
from desktop.formats.readings import LogFormat, read_log
from tests.scenarios import scenario

RATE = 50.0     # Hz, the logs' time column


@pytest.fixture(scope="module")
def field():
    raw, _, _ = scenario(2, "tumble", n=400, noise=0.1)
    return raw


def write(path, header, rows, meta=(), delimiter=","):
    lines = list(meta) + ([delimiter.join(header)] if header else [])
    lines += [delimiter.join(r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


# (name, unit's nT, how the log is laid out, the LogFormat that reads it)
LAYOUTS = [
    ("plain_nT", 1.0, dict(header=["x", "y", "z"]), {}),
    ("whitespace_uT_no_header", 1e3, dict(header=None, delimiter="  "), dict(unit="uT")),
    ("semicolon_mG_time", 100.0, dict(header=["time", "mag_x", "mag_y", "mag_z"], delimiter=";", time=1.0),
     dict(unit="mG")),
    ("gauss_imu_by_name", 1e5, dict(header=["ax", "ay", "az", "mx", "my", "mz"], accel=True), dict(unit="G")),
    ("gauss_imu_by_index", 1e5, dict(header=None, accel=True), dict(unit="G", columns="3,4,5")),
    ("counts_after_metadata", 8.0, dict(header=["mx", "my", "mz"], meta=("Fs,50.00", "Initialization time,60")),
     dict(unit="counts", scale=8.0, skip=2)),
    ("tab_ms_time", 1.0, dict(header=["t_ms", "Bx", "By", "Bz"], delimiter="\t", time=1e-3), {}),
    ("named_columns_reordered", 1.0, dict(header=["sensor_z", "sensor_x", "sensor_y"], order=(2, 0, 1)),
     dict(columns="sensor_x,sensor_y,sensor_z")),
]


@pytest.mark.parametrize("name, per_unit, layout, fmt", LAYOUTS, ids=[x[0] for x in LAYOUTS])
def test_every_layout_reads_to_the_same_nT(tmp_path, field, name, per_unit, layout, fmt):
    digits = 6
    values = field / per_unit
    rows = []
    for i, v in enumerate(values):
        cells = ["%.*e" % (digits, c) for c in v]
        if layout.get("order"):
            cells = [cells[k] for k in layout["order"]]
        if layout.get("accel"):
            cells = ["0.01", "-0.02", "1.0"] + cells
        if layout.get("time"):
            cells = ["%.3f" % (i / RATE / layout["time"])] + cells
        rows.append(cells)
    path = write(tmp_path / (name + ".txt"), layout.get("header"), rows, layout.get("meta", ()),
                 layout.get("delimiter", ","))
    h, t = read_log(path, LogFormat(**fmt))
    # written with 7 significant digits: each value is exact to half a unit of the 7th
    assert np.allclose(h, field, rtol=0.5 * 10.0 ** -digits, atol=0), name
    if layout.get("time"):
        assert t is not None and np.allclose(t, np.arange(len(field)) / RATE, atol=1e-3 / RATE)
    else:
        assert t is None


def test_an_explicit_time_column_by_index(tmp_path, field):
    rows = [["%d" % (i * 20), "%.4f" % x, "%.4f" % y, "%.4f" % z] for i, (x, y, z) in enumerate(field)]
    path = write(tmp_path / "log.csv", None, rows)
    h, t = read_log(path, LogFormat(columns="1,2,3", time_column="0"))
    assert np.array_equal(t, 20.0 * np.arange(len(field)))


def one_line_error(capsys, *argv):
    code = main(list(argv))
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and err.startswith("fluxcal: "), err
    return err


def test_gauss_read_as_nT_says_unit_G(tmp_path, capsys, field):
    path = write(tmp_path / "g.csv", ["x", "y", "z"], [["%.6f" % c for c in v] for v in field / 1e5])
    err = one_line_error(capsys, "fit", path, "-o", str(tmp_path / "c.json"))
    assert "look like G: add --unit G" in err
    assert not (tmp_path / "c.json").exists()


@pytest.mark.parametrize("argv, fragment", [
    (["--unit", "counts"], "--unit counts needs --scale NT_PER_COUNT"),
    (["--scale", "8"], "--scale applies to --unit counts only"),
    (["--unit", "counts", "--scale", "0"], "--scale must be a positive number"),
    (["--columns", "mx,my"], "--columns takes three names or 0-based indices"),
    (["--columns", "mx,my,bz"], "no field column 'bz'; the header has ax,ay,az,mx,my,mz"),
    (["--columns", "3,4,9"], "field column 9, but the log has 6 columns"),
])
def test_bad_options_are_one_line(tmp_path, capsys, field, argv, fragment):
    rows = [["0", "0", "1"] + ["%.6f" % c for c in v] for v in field / 1e5]
    path = write(tmp_path / "imu.csv", ["ax", "ay", "az", "mx", "my", "mz"], rows)
    err = one_line_error(capsys, "fit", path, "-o", str(tmp_path / "c.json"), *argv)
    assert fragment in err, err


def test_metadata_lines_name_the_skip_that_reads_them(tmp_path, capsys, field):
    rows = [["%d" % round(c) for c in v] for v in field / 8.0]
    path = write(tmp_path / "qmc.csv", ["mx", "my", "mz"], rows, meta=("Fs,50.00", "Initialization time,60"))
    err = one_line_error(capsys, "fit", path, "-o", str(tmp_path / "c.json"), "--unit", "counts", "--scale", "8")
    assert "--skip 2" in err


def test_an_accelerometer_beside_the_field_is_not_taken_for_it(tmp_path, capsys, field):
    rows = [["0", "0", "1"] + ["%.1f" % c for c in v] for v in field]
    path = write(tmp_path / "imu.csv", ["acc_x", "acc_y", "acc_z", "mag_x", "mag_y", "mag_z"], rows)
    assert np.allclose(read_log(path)[0], field, atol=0.05)
    # two magnetometers' x, y, z: which one to fit is for the user to say
    path = write(tmp_path / "two.csv", ["mag1_x", "mag1_y", "mag1_z", "mag2_x", "mag2_y", "mag2_z"], rows)
    err = one_line_error(capsys, "fit", path, "-o", str(tmp_path / "c.json"))
    assert "columns mag1_x,mag2_x for x" in err and "--columns X,Y,Z" in err
    h, _ = read_log(path, LogFormat(columns="mag2_x,mag2_y,mag2_z"))
    assert np.allclose(h, field, atol=0.05)


def test_a_capture_takes_no_log_options(tmp_path, capsys):
    from desktop.cli import main as cli
    cap = tmp_path / "c.npz"
    assert cli(["simulate", "-o", str(cap), "--seconds", "2", "--rate", "125"]) == 0
    capsys.readouterr()
    err = one_line_error(capsys, "fit", str(cap), "-o", str(tmp_path / "c.json"), "--unit", "G")
    assert "are for text logs" in err


def test_report_uses_the_logs_time_and_says_when_there_is_none(tmp_path, capsys, field):
    pytest.importorskip("matplotlib")
    timed = write(tmp_path / "timed.csv", ["sec", "x", "y", "z"],
                  [["%.3f" % (i / RATE)] + ["%.4f" % c for c in v] for i, v in enumerate(field)])
    plain = write(tmp_path / "plain.csv", ["x", "y", "z"], [["%.4f" % c for c in v] for v in field])
    assert main(["report", timed, "-o", str(tmp_path / "timed")]) == 0
    assert main(["report", plain, "-o", str(tmp_path / "plain")]) == 0
    assert "| samples | %d over %.1f s |" % (len(field), (len(field) - 1) / RATE) in (tmp_path / "timed" / "summary.md").read_text()
    assert "| samples | %d |" % len(field) in (tmp_path / "plain" / "summary.md").read_text()


def test_the_magnitude_plot_labels_sample_numbers_as_such(field):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from desktop.cli._report_figures import _magnitude
    for t, label in ((None, "sample number"), (np.arange(len(field)) / RATE, "time (s)")):
        fig = _magnitude(plt, field, field, t, None, None, None)
        assert fig.axes[-1].get_xlabel().startswith(label)
        plt.close(fig)


def test_format_errors_name_the_file(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("# only a comment\n\n")
    with pytest.raises(FormatError, match="empty.csv: empty file"):
        read_log(str(path))
    # every reader says a missing file, a folder and a text file given for a capture in the same words
    from desktop.formats.calibration import load_calibration
    from desktop.formats.capture import load_capture
    for load in (read_log, load_calibration, load_capture):
        with pytest.raises(FormatError, match="gone.json: no such file$"):
            load(str(tmp_path / "gone.json"))
    with pytest.raises(FormatError, match=": a folder, not a file$"):
        load_calibration(str(tmp_path))
    with pytest.raises(FormatError, match=r"empty.csv: not a fluxcal capture \(not an .npz"):
        load_capture(str(path))


@pytest.mark.parametrize("rows, said", [
    ("foo,bar,baz\n1,2,three\nhello world\n", "line 2: expected numbers in x,y,z"),   # not line 4's short row
    ("1,2,3\n4,5\n1,2,three\n", "line 3 has fewer columns than the header (column 2 needed)"),
    ("1,2,3\n1,2,three\n4,5\n", "line 3: expected numbers in x,y,z"),
])
def test_a_bad_row_is_named_by_the_first_line_that_has_a_problem(tmp_path, rows, said):
    path = tmp_path / "bad.csv"
    path.write_text("x,y,z\n" + rows)
    with pytest.raises(FormatError, match="bad.csv: " + said.replace("(", "\\(").replace(")", "\\)")):
        read_log(str(path))


def test_a_spreadsheets_byte_order_mark_and_8_bit_text(tmp_path, field):
    rows = "".join("%.4f;%.4f;%.4f\n" % tuple(v) for v in field)
    bom = tmp_path / "excel.csv"
    bom.write_bytes(b"\xef\xbb\xbfBx;By;Bz\n" + rows.encode())
    latin = tmp_path / "latin.csv"
    latin.write_bytes("x (\xb5T);y (\xb5T);z (\xb5T)\n".encode("latin-1") + rows.encode())
    assert np.allclose(read_log(str(bom), LogFormat(columns="bx,by,bz"))[0], field, atol=1e-4)
    assert np.allclose(read_log(str(latin))[0], field, atol=1e-4)
    binary = tmp_path / "capture.bin"
    binary.write_bytes(b"\x00\x01\x02" * 100)
    with pytest.raises(FormatError, match="not a text file"):
        read_log(str(binary))


def test_correct_reads_the_log_as_fit_does(tmp_path, capsys, field):
    path = write(tmp_path / "g.csv", ["ax", "ay", "az", "mx", "my", "mz"],
                 [["0", "0", "1"] + ["%.8f" % c for c in v] for v in field / 1e5])
    assert main(["fit", path, "--unit", "G", "-o", str(tmp_path / "c.json")]) == 0
    assert main(["correct", str(tmp_path / "c.json"), path, "--unit", "G", "-o", str(tmp_path / "out.csv")]) == 0
    table = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)
    assert table.shape == (len(field), 4)
    # the field's 0.1 nT noise, and the 1e-8 G = 1e-3 nT of the written digits
    assert table[:, 3].std() < 0.5


def test_numpys_commented_header_names_the_columns(tmp_path, field):
    # np.savetxt's default: the header behind "# "
    data = np.column_stack([np.arange(len(field)) / RATE, np.zeros(len(field)), field])
    path = tmp_path / "saved.txt"
    np.savetxt(path, data, header="time gyro_z mag_x mag_y mag_z", fmt="%.4f")
    h, t = read_log(str(path))
    assert np.allclose(h, field, atol=1e-4) and np.allclose(t, np.arange(len(field)) / RATE)
