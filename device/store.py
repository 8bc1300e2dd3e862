"""Atomic, checksummed JSON records on a flash filesystem (FAT or littlefs).

(Named store, not storage: CircuitPython's built-in `storage` would shadow it.)

    store.save(root, "cal", body_dict)          # cal.tmp -> (cal.json -> cal.bak) -> cal.json
    body, source, problem = store.load(root, "cal")   # (None, None, None): no record yet
    store.remove(root, "cal")                   # every file of it; OSError if one stays

save and remove raise OSError, and only OSError (MemoryError aside), when the
change does not stick; load never raises.

File layout: the JSON body on the first line, then "#crc32=xxxxxxxx" over the
body's exact bytes (MicroPython dicts do not keep key order, so the checksum
covers the stored text, not a re-serialisation).

Why three files: FatFs cannot rename over an existing file, so replacing
cal.json takes two renames with a window between them in which power can fail.
The new record is complete and checksummed in cal.tmp before anything is
renamed (it is read back first: a write that did not stick is an OSError, not a
record); the old one survives as cal.bak. `load` tries cal.json, then cal.tmp
(a power cut between the renames), then cal.bak, and says which one it used.
tests/test_reliability_storage.py cuts the power at every step of a save and breaks
the files every way (tests/micropython/store_faults.py, a failing flash mounted as a
user VFS in the real interpreters).
"""

import json
import os

try:
    from binascii import crc32
except ImportError:  # CircuitPython builds without binascii.crc32
    def crc32(data, crc=0):
        crc ^= 0xFFFFFFFF
        for b in data:
            crc ^= b
            for _ in range(8):
                crc = (crc >> 1) ^ (0xEDB88320 & -(crc & 1))
        return crc ^ 0xFFFFFFFF

MAX_BYTES = 8192  # larger files are not ours: refuse before reading them into RAM
_ENOENT = 2     # errno values (the same on every MicroPython port)
_EIO = 5
_EINVAL = 22


def file_path(root, name):
    """root/name; a root of "" is the current folder (the flash's root on a board: "/" on
    rp2 and esp32, "/flash" on a pyboard), so the same names work on every port."""
    return root + "/" + name if root else name


def free_bytes(root):
    """Bytes free on the filesystem of root, or None where the port cannot say (no statvfs)."""
    try:
        s = os.statvfs(root or ".")
        return s[0] * s[4]   # f_bsize * f_bavail
    except (OSError, AttributeError):
        return None


def _exists(path):
    try:
        os.stat(path)
        return True
    except OSError:
        return False


def _remove(path):
    try:
        os.remove(path)
    except OSError:
        pass


def _sync():
    if hasattr(os, "sync"):
        os.sync()  # flush FAT sectors (no-op where the port has no os.sync)


def _why(e):
    """An exception as a short reason: its message, or its class name when it has none
    (KeyError, RuntimeError and the like are named, ValueError and OSError speak for themselves)."""
    msg = str(e)
    if isinstance(e, (ValueError, OSError)):
        return msg or e.__class__.__name__
    return "%s: %s" % (e.__class__.__name__, msg) if msg else e.__class__.__name__


def encode(body):
    text = json.dumps(body)
    return "%s\n#crc32=%08x\n" % (text, crc32(text.encode()) & 0xFFFFFFFF)


def decode(data):
    """Body dict from file text; ValueError saying what is wrong."""
    if len(data) > MAX_BYTES:
        raise ValueError("file too large")
    lines = data.split("\n")
    if len(lines) < 2 or not lines[1].startswith("#crc32="):
        raise ValueError("no checksum line (truncated?)")
    text = lines[0]
    try:
        want = int(lines[1][7:], 16)
    except ValueError:
        raise ValueError("bad checksum line")
    if crc32(text.encode()) & 0xFFFFFFFF != want:
        raise ValueError("checksum mismatch")
    body = json.loads(text)
    if not isinstance(body, dict):
        raise ValueError("record is not an object")
    return body


def _read_bytes(path):
    # the file's own size, not MAX_BYTES: a save reads its record back, and an
    # 8 KB buffer on a fragmented heap would fail where the record fits
    size = os.stat(path)[6]
    if size > MAX_BYTES:
        raise ValueError("file too large")
    with open(path, "rb") as f:
        return f.read(size)


def _read(path):
    data = _read_bytes(path)
    try:
        return data.decode()
    except UnicodeError:
        raise ValueError("not text")


def save(root, name, body):
    """Write body atomically; the previous record stays as NAME.bak (a torn NAME.json is
    dropped instead, so the good NAME.bak beside it stays).

    Raises OSError, and only OSError, for every failure to make the record stick:
    the file system's own errors (full, read-only, I/O), a short write, a read-back
    that differs from what was written (a flash write that silently did not stick),
    and a body that cannot be stored so that load accepts it (not JSON-encodable,
    NaN or infinity, too large: errno EINVAL). Whatever fails, load still finds the
    previous record. MemoryError passes through (the caller says "no memory").
    """
    final = file_path(root, name + ".json")
    tmp = file_path(root, name + ".tmp")
    bak = file_path(root, name + ".bak")
    try:
        text = encode(body)
        decode(text)   # what load would refuse (MicroPython writes NaN as nan) is never written
        data = text.encode()
    except MemoryError:
        raise
    except Exception as e:  # noqa: BLE001 - TypeError, ValueError, RecursionError from json.dumps
        raise OSError(_EINVAL, "%s: record cannot be stored: %s" % (name, _why(e)))
    if not _exists(final) and _exists(tmp):
        # a save cut between its renames left the newest record in cal.tmp, and load could
        # not move it into place: do that now, before cal.tmp is overwritten
        try:
            decode(_read(tmp))
            os.rename(tmp, final)
        except ValueError:
            pass   # a torn cal.tmp holds nothing to keep
    try:
        with open(tmp, "wb") as f:
            n = f.write(data)
        if n is not None and n != len(data):
            raise OSError(_EIO, "%s.tmp: short write (%d of %d bytes)" % (name, n, len(data)))
        _sync()
        # read back: a flash write that did not stick must not replace a good file
        try:
            back = _read_bytes(tmp)
        except ValueError as e:
            raise OSError(_EIO, "%s.tmp: read-back failed: %s" % (name, e))
        if back != data:
            raise OSError(_EIO, "%s.tmp: read-back differs from what was written (%d of %d bytes)"
                          % (name, len(back), len(data)))
    except OSError:
        _remove(tmp)   # a partial cal.tmp helps nobody; load would only report it
        raise
    if _exists(final):
        try:
            decode(_read(final))
            keep = True
        except ValueError:
            keep = False   # a torn cal.json is no backup: the good cal.bak beside it stays
        if keep:
            _remove(bak)
            os.rename(final, bak)   # FAT cannot rename over a file: the old record moves aside first
        else:
            os.remove(final)
    os.rename(tmp, final)
    _sync()


def load(root, name, validate=None):
    """(body, source, problem): source is "json", "tmp", "bak" or None.

    problem names every file that exists but was refused (and why), else it is
    None: no file at all is no problem, just no record. validate(body) may
    raise ValueError to reject a record that parses but makes no sense (e.g.
    Calibration.from_dict). Never raises: whatever a file or the validator
    raises refuses that file, named in problem, so no stored record can stop a boot.
    """
    problems = []
    for ext in ("json", "tmp", "bak"):
        path = file_path(root, name + "." + ext)
        if not _exists(path):
            continue
        try:
            body = decode(_read(path))
            if validate is not None:
                validate(body)
        except Exception as e:  # noqa: BLE001 - a record must never stop the boot
            problems.append("%s.%s: %s" % (name, ext, _why(e)))
            continue
        if ext == "tmp":
            # power failed between the renames: finish the job
            try:
                final = file_path(root, name + ".json")
                _remove(final)
                os.rename(path, final)
            except OSError:
                pass
        return body, ext, "; ".join(problems) or None
    return None, None, "; ".join(problems) or None


def remove(root, name):
    """Delete the record's files. Raises OSError when a file exists and cannot be deleted
    (a read-only filesystem), so a caller never reports a record gone that the next boot
    loads. Oldest first (bak, tmp, json) and stopping at the first failure: what stays
    is the newest record, never an older one in its place."""
    for ext in ("bak", "tmp", "json"):
        path = file_path(root, name + "." + ext)
        try:
            os.remove(path)
        except OSError as e:
            # a missing file is gone already (FAT on a read-only volume says EROFS even then)
            if (e.args and e.args[0] == _ENOENT) or not _exists(path):
                continue
            raise
