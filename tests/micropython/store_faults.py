# Runs under each interpreter (the micropython builds, CircuitPython): device/store.py on a
# flash that fails on demand (faulty_flash.py, beside this script: a script's folder comes
# first on sys.path on every port). argv: ROW REPO_ROOT. Prints one JSON line {"row",
# "cases", "failures"}: the cases run and, for each that broke the store's contract, what
# happened. The contract (tests/test_reliability_storage.py says it row by row):
# - a load never returns a record that was not saved whole (no corrupt calibration), and
#   returns one whenever one was stored before (never "none" after a failed save);
# - a failed save keeps the previous record, and raises OSError and nothing else;
# - a record that cannot be removed makes remove raise OSError;
# - load's `problem` names every file it refused.
import json
import os
import sys

from faulty_flash import MOUNT, ROOT, PowerLoss, mounted
from store_contract import NEW, OLD, OLDER, Row, stored, validate


# ---- starting states of the flash ----
def states(store):
    """name -> (files, the records a load may give: before and after the save)."""
    def good(b):
        return stored(store, b)

    partial = good(OLDER)[:37]
    return {
        "empty": ({}, [None]),
        "json": ({"cal.json": good(OLD)}, [OLD]),
        "json+bak": ({"cal.json": good(OLD), "cal.bak": good(OLDER)}, [OLD]),
        "json+bak+torn-tmp": ({"cal.json": good(OLD), "cal.bak": good(OLDER), "cal.tmp": partial}, [OLD]),
        # an earlier save cut between its renames
        "tmp+bak": ({"cal.tmp": good(OLD), "cal.bak": good(OLDER)}, [OLD]),
        # a torn cal.json (flash worn out under it): the previous good one is cal.bak
        "bad-json+bak": ({"cal.json": good(OLD)[:50], "cal.bak": good(OLDER)}, [OLDER]),
    }


def copy(files):
    return dict(files)


def row_power_loss():
    """Power cut at every step of a save, each way a step can be torn, from every state."""
    r = Row("power_loss")
    _, store = mounted({})
    for sname, (start, before) in states(store).items():
        dry, store = mounted(copy(start))
        store.save(ROOT, "cal", NEW)
        steps = list(dry.steps)
        for k in range(1, len(steps) + 2):     # the last: no cut at all
            op = steps[k - 1].split()[0] if k <= len(steps) else "none"
            torns = {"write": ("none", "half", "all"), "rename": ("none", "both")}.get(op, ("none",))
            for torn in torns:
                r.case()
                label = "%s, cut at step %d/%d (%s, %s)" % (sname, k, len(steps),
                                                            steps[k - 1] if k <= len(steps) else "none", torn)
                files = copy(start)
                _, store = mounted(files, cut=k, torn=torn)
                try:
                    store.save(ROOT, "cal", NEW)
                    if k <= len(steps):
                        r.fail(label, "save returned through a power cut")
                except PowerLoss:
                    if k > len(steps):
                        r.fail(label, "power lost with no cut")
                except Exception as e:  # noqa: BLE001
                    r.fail(label, "save raised %r" % (e,))
                # what a load may give: the record before, or the new one once its tmp is whole
                had_json = "cal.json" in files
                body, src, problem = r.check_load(label, files, before + [NEW])
                if k > len(steps):
                    if body != NEW:
                        r.fail(label, "a save without a cut did not stick")
                    # the previous good record is the backup (a torn cal.json is not kept as one)
                    if before[0] is not None:
                        try:
                            if store.decode(files.get("cal.bak", b"").decode()) != before[0]:
                                r.fail(label, "cal.bak is not the previous record")
                        except ValueError as e:
                            r.fail(label, "cal.bak is not the previous record: %s" % e)
                # named: a cal.json that is there but refused
                if src not in (None, "json") and had_json and (problem is None or "cal.json" not in problem):
                    r.fail(label, "cal.json refused without naming it: %r" % (problem,))
                # the store works on after the cut: one more save sticks
                _, store = mounted(files)
                try:
                    store.save(ROOT, "cal", OLDER)
                except Exception as e:  # noqa: BLE001
                    r.fail(label, "the next save raised %r" % (e,))
                r.check_load(label + ", next save", files, [OLDER])
    return r


def row_power_loss_in_recovery():
    """Power cut at every step of load's own repair (cal.tmp renamed into cal.json)."""
    r = Row("power_loss_recovery")
    _, store = mounted({})
    for sname, start in (("tmp+bak", {"cal.tmp": stored(store, OLD), "cal.bak": stored(store, OLDER)}),
                         ("bad-json+tmp+bak", {"cal.json": b"{\"matr", "cal.tmp": stored(store, OLD),
                                               "cal.bak": stored(store, OLDER)})):
        dry, store = mounted(copy(start))
        store.load(ROOT, "cal", validate)
        for k in range(1, len(dry.steps) + 1):
            for torn in ("none", "both"):
                r.case()
                label = "%s, cut at repair step %d (%s, %s)" % (sname, k, dry.steps[k - 1], torn)
                files = copy(start)
                _, store = mounted(files, cut=k, torn=torn)
                try:
                    store.load(ROOT, "cal", validate)
                except PowerLoss:
                    pass
                except Exception as e:  # noqa: BLE001
                    r.fail(label, "load raised %r" % (e,))
                r.check_load(label, files, [OLD])
    return r


def row_truncation():
    """Each file of the record cut at every length (a torn write, a worn sector)."""
    r = Row("truncation")
    _, store = mounted({})
    new, old = stored(store, NEW), stored(store, OLD)
    whole = len(new) - 1    # all but the last newline: the record and its checksum are whole
    for n in range(whole):
        # the primary torn, the previous record beside it
        r.case()
        r.check_load("cal.json[:%d] beside cal.bak" % n, {"cal.json": new[:n], "cal.bak": old}, [OLD], ("cal.json",))
        # the only copy torn: no record, and the problem says which file and why
        r.case()
        r.check_load("cal.json[:%d] alone" % n, {"cal.json": new[:n]}, [None], ("cal.json",))
        # a torn tmp (a save cut mid-write) beside a good primary is ignored
        r.case()
        r.check_load("cal.tmp[:%d] beside cal.json" % n, {"cal.json": old, "cal.tmp": new[:n]}, [OLD])
        # torn tmp, no primary, the backup good
        r.case()
        r.check_load("cal.tmp[:%d] beside cal.bak" % n, {"cal.tmp": new[:n], "cal.bak": old}, [OLD], ("cal.tmp",))
    r.case()
    r.check_load("cal.json without its last newline", {"cal.json": new[:whole]}, [NEW])
    return r


def row_flipped_bytes():
    """Every byte of cal.json changed three ways (all bits, the lowest bit, zeroed)."""
    r = Row("flipped_bytes")
    _, store = mounted({})
    new, old = stored(store, NEW), stored(store, OLD)
    for i in range(len(new)):
        for how in ("xff", "x01", "zero"):
            b = bytearray(new)
            b[i] = {"xff": b[i] ^ 0xFF, "x01": b[i] ^ 0x01, "zero": 0}[how]
            b = bytes(b)
            if b == new:
                continue
            r.case()
            _, src, problem = r.check_load("cal.json byte %d %s, cal.bak good" % (i, how),
                                              {"cal.json": b, "cal.bak": old}, [NEW, OLD])
            if src == "bak" and (problem is None or "cal.json" not in problem):
                r.fail("byte %d %s" % (i, how), "cal.json refused without naming it: %r" % (problem,))
            r.case()
            r.check_load("cal.json byte %d %s alone" % (i, how), {"cal.json": b}, [NEW, None])
    return r


def _failing_save(r, label, files, fault, before, body=NEW):
    """A save that cannot stick: it must raise OSError (exactly) and keep `before`."""
    r.case()
    _, store = mounted(files, fault=fault)
    try:
        store.save(ROOT, "cal", body)
        r.fail(label, "save returned as if the record had stuck")
    except OSError:
        pass
    except BaseException as e:  # noqa: BLE001 - PowerLoss included: no save may raise it here
        r.fail(label, "save raised %s (%r), not OSError" % (e.__class__.__name__, e))
    r.check_load(label, files, [before])


def _starts(store):
    return (("json+bak", {"cal.json": stored(store, OLD), "cal.bak": stored(store, OLDER)}, OLD),
            ("json", {"cal.json": stored(store, OLD)}, OLD),
            ("empty", {}, None))


def _failing_saves(name, faults):
    """Each fault from each starting state: save raises OSError, the record before stays,
    and no cal.tmp is left behind (load would only have it to report)."""
    r = Row(name)
    _, store = mounted({})
    for sname, start, before in _starts(store):
        for fault in faults:
            files = copy(start)
            _failing_save(r, "%s, %s" % (sname, fault), files, fault, before)
            if "cal.tmp" in files:
                r.fail("%s, %s" % (sname, fault), "a cal.tmp that did not stick was left behind")
    return r


def row_full():
    """A full filesystem: ENOSPC at open (no directory entry), at the first byte, part way,
    and when the file's cached tail is flushed at close."""
    return _failing_saves("full", ("enospc-open", "enospc-write", "enospc-partial", "enospc-close"))


def row_read_only():
    """A read-only filesystem (EROFS on open for write, remove, rename): a save and a
    clear fail loudly and the record stays; a load still works, and still finds a record
    left in cal.tmp by a cut between renames even though it cannot repair the files."""
    r = Row("read_only")
    _, store = mounted({})
    for sname, start, before in _starts(store):
        files = copy(start)
        _failing_save(r, "%s, save" % sname, files, "erofs", before)
        r.case()
        label = "%s, remove" % sname
        _, store = mounted(files, fault="erofs")
        try:
            store.remove(ROOT, "cal")
            if before is not None:
                r.fail(label, "remove returned but the record is still there")
        except OSError:
            if before is None:
                r.fail(label, "remove raised with nothing to remove")
        except BaseException as e:  # noqa: BLE001 - PowerLoss included: no save may raise it here
            r.fail(label, "remove raised %r, not OSError" % (e,))
        r.check_load(label, files, [before])
    r.case()
    files = {"cal.tmp": stored(store, OLD), "cal.bak": stored(store, OLDER)}
    _, store = mounted(files, fault="erofs")
    body, src, _ = store.load(ROOT, "cal", validate)
    if body != OLD or src != "tmp":
        r.fail("tmp+bak read-only", "load gave %s from %s" % (body, src))
    return r


def row_short_write():
    """A write that does not stick and raises nothing: a count short of the data, a full
    count over half the data, nothing written, one byte wrong. The read-back finds it."""
    return _failing_saves("short_write", ("short-count", "short-silent", "lost", "rot"))


def row_remove():
    """clear: every file gone; a file that cannot be deleted raises OSError and what stays
    is the newest record, never an older one in its place."""
    r = Row("remove")
    _, store = mounted({})
    full = {"cal.json": stored(store, OLD), "cal.bak": stored(store, OLDER), "cal.tmp": stored(store, OLD)[:20]}
    r.case()
    files = copy(full)
    _, store = mounted(files)
    store.remove(ROOT, "cal")
    if files:
        r.fail("remove", "left %s" % sorted(files))
    r.check_load("after remove", files, [None])
    r.case()
    files = {}
    _, store = mounted(files)
    store.remove(ROOT, "cal")    # nothing there: nothing to say
    r.case()
    files = copy(full)
    _, store = mounted(files, fault="eio-remove-json")
    try:
        store.remove(ROOT, "cal")
        r.fail("cal.json cannot be removed", "remove returned")
    except OSError:
        pass
    except BaseException as e:  # noqa: BLE001 - PowerLoss included: no save may raise it here
        r.fail("cal.json cannot be removed", "remove raised %r" % (e,))
    r.check_load("cal.json cannot be removed", files, [OLD])
    return r


def row_implausible():
    """A record stored whole, checksum right, that no sensor can have (as a set-cal of an
    older firmware could have stored): refused by the validator and named; the backup used."""
    r = Row("implausible")
    _, store = mounted({})
    bad = []
    b = dict(NEW, meta=dict(NEW["meta"], temperature_c="hot"))
    bad.append(("meta.temperature_c a string", b))
    bad.append(("field 1e-3", dict(NEW, field=1e-3)))
    bad.append(("field 1e308", dict(NEW, field=1e308)))
    bad.append(("offset 1e12", dict(NEW, offset=[1e12, 0.0, 0.0])))
    bad.append(("matrix not a list", dict(NEW, matrix="eye")))
    bad.append(("meta a list", dict(NEW, meta=[1, 2])))
    bad.append(("diagnostics nested", dict(NEW, diagnostics={"rms": {"a": [1]}})))
    bad.append(("not a calibration", {"a": 1}))
    for label, body in bad:
        r.case()
        r.check_load(label, {"cal.json": stored(store, body), "cal.bak": stored(store, OLD)}, [OLD], ("cal.json",))
    return r


def row_unstorable():
    """A body json cannot carry faithfully (NaN and infinity, which MicroPython writes as
    nan and inf; an object, which it writes as its repr or refuses; a nesting deeper than
    its recursion): save raises OSError and writes nothing."""
    r = Row("unstorable")
    deep = []
    for _ in range(3000):
        deep = [deep]
    for label, body in (("nan", dict(NEW, field=float("nan"))), ("inf", dict(NEW, field=float("inf"))),
                        ("object", dict(NEW, meta={"x": Row("x")})), ("deep", dict(NEW, meta={"x": deep}))):
        _, store = mounted({})
        files = {"cal.json": stored(store, OLD)}
        _failing_save(r, label, files, None, OLD, body)
        if "cal.tmp" in files:
            r.fail(label, "cal.tmp written")
    return r


ROWS = {"power_loss": row_power_loss, "power_loss_recovery": row_power_loss_in_recovery,
        "truncation": row_truncation, "flipped_bytes": row_flipped_bytes, "full": row_full,
        "read_only": row_read_only, "short_write": row_short_write, "remove": row_remove,
        "implausible": row_implausible, "unstorable": row_unstorable}


def main(row, repo):
    for p in (repo, repo + "/device"):
        if p not in sys.path:
            sys.path.insert(0, p)
    r = ROWS[row]()
    try:
        os.umount(MOUNT)
    except OSError:
        pass
    print(json.dumps({"row": r.name, "cases": r.cases, "failures": r.failures}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
