"""Atomic, checksummed JSON records on a flash filesystem (FAT or littlefs).

(Named store, not storage: CircuitPython's built-in `storage` would shadow it.)

    store.save(root, "cal", body_dict)          # cal.tmp -> (cal.json -> cal.bak) -> cal.json
    body, source, problem = store.load(root, "cal")   # (None, None, None): no record yet

File layout: the JSON body on the first line, then "#crc32=xxxxxxxx" over the
body's exact bytes (MicroPython dicts do not keep key order, so the checksum
covers the stored text, not a re-serialisation).

Why three files: FatFs cannot rename over an existing file, so replacing
cal.json takes two renames with a window between them in which power can fail.
The new record is complete and checksummed in cal.tmp before anything is
renamed; the old one survives as cal.bak. `load` tries cal.json, then cal.tmp
(a power cut between the renames), then cal.bak, and says which one it used.
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


def file_path(root, name):
    """root/name; a root of "" is the current folder (the flash's root on a board: "/" on
    rp2 and esp32, "/flash" on a pyboard), so the same names work on every port."""
    return root + "/" + name if root else name


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


def _read(path):
    # the file's own size, not MAX_BYTES: a save reads its record back, and an
    # 8 KB buffer on a fragmented heap would fail where the record fits
    size = os.stat(path)[6]
    if size > MAX_BYTES:
        raise ValueError("file too large")
    with open(path, "rb") as f:
        data = f.read(size)
    try:
        return data.decode()
    except UnicodeError:
        raise ValueError("not text")


def save(root, name, body):
    """Write body atomically; the previous record stays as NAME.bak."""
    final = file_path(root, name + ".json")
    tmp = file_path(root, name + ".tmp")
    bak = file_path(root, name + ".bak")
    data = encode(body)
    with open(tmp, "w") as f:
        f.write(data)
    if hasattr(os, "sync"):
        os.sync()  # flush FAT sectors before the renames
    decode(_read(tmp))  # read back: a flash write that did not stick must not replace a good file
    if _exists(final):
        _remove(bak)
        os.rename(final, bak)
    os.rename(tmp, final)
    if hasattr(os, "sync"):
        os.sync()


def load(root, name, validate=None):
    """(body, source, problem): source is "json", "tmp", "bak" or None.

    problem names every file that exists but was refused (and why), else it is
    None: no file at all is no problem, just no record. validate(body) may
    raise ValueError to reject a record that parses but makes no sense (e.g.
    Calibration.from_dict). Never raises.
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
        except (OSError, ValueError, KeyError, TypeError) as e:
            problems.append("%s.%s: %s" % (name, ext, e))
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
    for ext in ("json", "tmp", "bak"):
        _remove(file_path(root, name + "." + ext))
