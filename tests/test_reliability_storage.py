"""The storage rows of the reliability matrix (issue 10), on the real interpreters.

device/store.py runs unchanged in each interpreter a board has, over a flash
filesystem stand-in mounted with os.mount as a user VFS
(tests/micropython/store_faults.py): FAT-like (no rename over a file), every change a
step at which the power can be cut, and faults on demand. Each test runs one row of
cases there and fails with every case that broke the contract:

- a load never gives a record that was not saved whole, and gives one whenever one was
  stored before (never "none" after a failed save); its `problem` names what it refused;
- a save that does not stick raises OSError, nothing else, and keeps the previous record;
- a remove that cannot delete a file raises OSError (clear-cal must not answer ok for a
  calibration the next boot loads).
"""

import json
import os
import subprocess

import pytest

from tests.interpreters import INTERPRETERS, need

SCRIPT = os.path.join(os.path.dirname(__file__), "micropython", "store_faults.py")


def run_row(name, row, root):
    proc = subprocess.run([need(name), SCRIPT, row, root], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr or proc.stdout
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["failures"] == [], "\n".join(out["failures"])
    return out["cases"]


@pytest.mark.parametrize("name", INTERPRETERS)
def test_power_loss_at_every_step_of_a_save(name, root):
    """Cut at each of the save's steps (open, write, close, sync, remove, rename, sync),
    a write torn to nothing, half or all of its bytes, a rename leaving both names, from
    six starting states (no record; cal.json; cal.json and cal.bak; a torn cal.tmp beside
    them; a record left in cal.tmp by an earlier cut; a torn cal.json beside a good
    cal.bak): a fresh load gives the record from before or the new one, never none or a
    torn one; a torn cal.json is named; the next save sticks; an uncut save leaves the
    previous good record as cal.bak."""
    assert run_row(name, "power_loss", root) >= 70


@pytest.mark.parametrize("name", INTERPRETERS)
def test_power_loss_while_load_repairs_a_cut_save(name, root):
    """load moves a whole cal.tmp into place (a cut between the renames); cut at each of
    its steps, the next load still gives that record."""
    assert run_row(name, "power_loss_recovery", root) >= 8


@pytest.mark.parametrize("name", INTERPRETERS)
def test_truncation_at_every_length(name, root):
    """cal.json cut at every length beside a good cal.bak: cal.bak, cal.json named; alone:
    no record, cal.json named; a torn cal.tmp beside cal.json ignored, beside cal.bak named."""
    assert run_row(name, "truncation", root) >= 1700


@pytest.mark.parametrize("name", INTERPRETERS)
def test_every_flipped_byte(name, root):
    """Every byte of cal.json inverted, its low bit flipped, zeroed: the CRC refuses it
    (cal.bak used and cal.json named, or no record), or the change was harmless (the
    checksum line's trailing whitespace) and the very record loads."""
    assert run_row(name, "flipped_bytes", root) >= 2500


@pytest.mark.parametrize("name", INTERPRETERS)
def test_full_filesystem(name, root):
    """ENOSPC at open, at the first byte, part way and at close: save raises OSError,
    the previous record (or none) stays, no partial cal.tmp is left."""
    assert run_row(name, "full", root) >= 12


@pytest.mark.parametrize("name", INTERPRETERS)
def test_read_only_filesystem(name, root):
    """EROFS on open for write, remove and rename: save and remove raise OSError and the
    record stays; load still finds a record left in cal.tmp although it cannot repair."""
    assert run_row(name, "read_only", root) >= 7


@pytest.mark.parametrize("name", INTERPRETERS)
def test_silent_short_write(name, root):
    """A write that returns a short count, claims all bytes over half of them, writes
    nothing, or writes one byte wrong, without an exception: the read-back catches it
    and save raises OSError (not the ValueError that stopped the main loop)."""
    assert run_row(name, "short_write", root) >= 12


@pytest.mark.parametrize("name", INTERPRETERS)
def test_remove_that_cannot_delete_raises(name, root):
    """remove deletes all three files; one it cannot delete raises OSError, and what stays
    is the newest record, not an older one resurrected."""
    assert run_row(name, "remove", root) >= 3


@pytest.mark.parametrize("name", INTERPRETERS)
def test_checksummed_but_implausible_record_is_refused(name, root):
    """A record stored whole that no sensor has (meta.temperature_c a string, field 1e-3
    or 1e308 nT, offset 1e12 codes, wrong types): the validator refuses it at load, the
    problem names cal.json, cal.bak is used."""
    assert run_row(name, "implausible", root) >= 8


@pytest.mark.parametrize("name", INTERPRETERS)
def test_unstorable_body_raises_oserror(name, root):
    """A body json cannot carry (NaN, inf, an object, nesting past the recursion limit):
    save raises OSError before writing anything."""
    assert run_row(name, "unstorable", root) >= 4
