"""A few simulated minutes of the long survey run (desktop/bench/longrun.py) on the real
`micropython`: the same code path as `python -m desktop.bench.longrun --hours 8`, the same
invariants (heap flat after warm-up, every frame accounted for and the frame counter
continuous against the DRDY edges the World delivered, output rate steady, rotating logs
within their bound), with tolerances from counting: a data event every 0.1 s is 600 a
complete simulated minute, +-1 where a minute's edge falls between a block's samples.
"""

import pytest

from desktop.bench import longrun
from desktop.bench.longrun_report import problems, table
from tests.interpreters import need


LOG_FILE_BYTES = 8192      # the default 64 KB would take 8 minutes to come round; here 4 x 8 KB, ~3 turns


@pytest.fixture(scope="module")
def figures():
    need("micropython")
    # a status every 0.5 s: the heap's ceiling is read from the best sample of a 40 s window, which
    # lies up to one interval after a collection, 0.5 s x ~11 KB/s = 6 KB below it, inside the 16 KB
    # bound. At 2 s it was up to 22 KB: where the collections fell against the replies (moved by
    # as little as the checkout's path or one more status key) decided it, 250,336 -> 229,248 B
    return longrun.run(180.0, every_s=0.5, settings={"log_file_bytes": LOG_FILE_BYTES})


def test_short_long_run_holds_every_invariant(figures):
    f = figures
    assert problems(f) == [], table(f)
    assert f["simulated_s"] > 179.0 and f["statuses"] >= 340
    # 180 s at the default 1000 SPS: every conversion counted once, none missed or merged
    assert f["frames"] >= 180 * longrun.DEFAULTS["rate"]
    assert f["missed"] == f["overflow"] == f["merged_edges"] == f["frames_vs_edges"] == 0
    lo, hi = f["per_minute"]
    assert 599 <= lo <= hi <= 601 and f["minutes"] >= 2
    # 10 lines a second of ~53 bytes: 95 KB through 4 files of 8 KB, overwritten in turn
    assert f["log_lines"] >= 10 * 175 and f["log_error"] is None
    assert f["log_files_max"] == f["log_files_allowed"] == 4
    assert f["log_bytes_max"] <= f["log_bytes_allowed"] == 4 * LOG_FILE_BYTES


# The run's wall time is a benchmark figure (docs/long-run.md, python -m desktop.bench.longrun),
# measured there, not asserted here: a shared machine's speed is not the firmware's behaviour.


def test_table_names_every_figure(figures):
    text = table(figures)
    for what in ("heap mem_free", "frame counter", "missed / overflow", "data events per simulated minute",
                 "log files", "log bytes"):
        assert what in text
