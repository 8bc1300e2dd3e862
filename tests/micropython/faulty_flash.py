# A stand-in for a board's flash filesystem that fails on demand, for store_faults.py
# (runs under each interpreter: the micropython builds, CircuitPython). Mounted with
# os.mount as a user VFS, so device/store.py's own `open`, os.stat, os.remove and
# os.rename go through it unchanged: `mounted(files, cut=..., torn=..., fault=...)` gives a
# fresh boot's view of `files` and store.py imported anew.
import os
import sys

MOUNT = "/fsim"
ROOT = MOUNT
ENOENT, EIO, EEXIST, ENOSPC, EROFS = 2, 5, 17, 28, 30
NAMES = ("cal.json", "cal.tmp", "cal.bak")


class PowerLoss(BaseException):
    """The power is cut: nothing after this point runs; only the flash's contents remain."""


class File:
    def __init__(self, fs, name, writing):
        self.fs = fs
        self.name = name
        self.writing = writing
        self.pos = 0
        self.closed = False

    def write(self, data):
        return self.fs.write(self.name, data)

    def read(self, n=-1):
        self.fs.alive()
        data = self.fs.files.get(self.name, b"")
        end = len(data) if n is None or n < 0 else min(len(data), self.pos + n)
        out = bytes(data[self.pos:end])
        self.pos = end
        return out

    def close(self):
        if not self.closed:
            self.closed = True
            if self.writing:
                self.fs.close(self.name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class Flash:
    """A FAT-like filesystem over `files` (name -> bytes: what survives a power cut).

    Like FatFs it cannot rename over an existing file. Every change is a step: open for
    write, write, close, remove, rename, sync. At step `cut` (1-based) the power goes
    while the step runs: a write lands as `torn` says ("none", "half" or "all" of its
    bytes), a rename as "none" or "both" (the new name written, the old not yet cleared),
    any other step not at all; from then on every call raises PowerLoss. `fault` makes
    the medium misbehave without a power cut (its names: see open, write, close, remove,
    rename, statvfs). Writes go straight to `files`: what a write returned has landed,
    unless a fault says otherwise.
    """

    def __init__(self, files, cut=0, torn="none", fault=None):
        self.files = files
        self.cut = cut
        self.torn = torn
        self.fault = fault
        self.steps = []
        self.dead = False

    # ---- the power ----
    def alive(self):
        if self.dead:
            raise PowerLoss()

    def step(self, op, name):
        """Count a change; True when the power goes during it (the caller applies `torn`)."""
        self.alive()
        self.steps.append(op + " " + name)
        if len(self.steps) == self.cut:
            self.dead = True
            return True
        return False

    # ---- the user VFS protocol (MicroPython's extmod/vfs.c calls these) ----
    def mount(self, readonly, mkfs):
        pass

    def umount(self):
        pass

    def _name(self, path):
        return path.lstrip("/")

    def open(self, path, mode):
        name = self._name(path)
        if "w" in mode or "a" in mode or "+" in mode:
            if self.step("open", name):
                raise PowerLoss()
            if self.fault == "erofs":
                raise OSError(EROFS)
            if self.fault == "enospc-open" and name not in self.files:
                raise OSError(ENOSPC)   # no free directory entry
            if "a" not in mode or name not in self.files:
                self.files[name] = b""
            return File(self, name, True)
        self.alive()
        if name not in self.files:
            raise OSError(ENOENT)
        return File(self, name, False)

    def write(self, name, data):
        if isinstance(data, str):
            data = data.encode()
        half = data[:len(data) // 2]
        if self.step("write", name):
            self.files[name] += {"none": b"", "half": half, "all": data}[self.torn]
            raise PowerLoss()
        f = self.fault
        if f == "enospc-write":
            raise OSError(ENOSPC)
        if f == "enospc-partial":
            self.files[name] += half
            raise OSError(ENOSPC)
        if f == "short-count":      # a short write that says so, without an exception
            self.files[name] += half
            return len(half)
        if f == "short-silent":     # a short write that claims to be whole
            self.files[name] += half
            return len(data)
        if f == "lost":             # nothing reached the medium, all bytes claimed
            return len(data)
        if f == "rot":              # every byte claimed, one of them wrong on the medium
            d = bytearray(data)
            d[len(d) // 3] ^= 0x10
            self.files[name] += bytes(d)
            return len(data)
        self.files[name] += data
        return len(data)

    def close(self, name):
        if self.step("close", name):
            raise PowerLoss()
        if self.fault == "enospc-close":   # the cached tail did not fit when flushed
            self.files[name] = self.files[name][:len(self.files[name]) // 2]
            raise OSError(ENOSPC)

    def sync(self):
        if self.step("sync", ""):
            raise PowerLoss()

    def stat(self, path):
        self.alive()
        name = self._name(path)
        if name == "":
            return (0x4000, 0, 0, 0, 0, 0, 0, 0, 0, 0)
        if name not in self.files:
            raise OSError(ENOENT)
        return (0x8000, 0, 0, 0, 0, 0, len(self.files[name]), 0, 0, 0)

    def remove(self, path):
        name = self._name(path)
        if self.step("remove", name):
            raise PowerLoss()
        if self.fault == "erofs":
            raise OSError(EROFS)      # FatFs on a read-only volume: even for a missing file
        if name not in self.files:
            raise OSError(ENOENT)
        if self.fault == "eio-remove-json" and name == "cal.json":
            raise OSError(EIO)
        del self.files[name]

    def rename(self, old, new):
        a, b = self._name(old), self._name(new)
        if self.step("rename", a + ">" + b):
            if self.torn == "both" and a in self.files and b not in self.files:
                self.files[b] = self.files[a]
            raise PowerLoss()
        if self.fault == "erofs":
            raise OSError(EROFS)
        if a not in self.files:
            raise OSError(ENOENT)
        if b in self.files:
            raise OSError(EEXIST)     # FatFs cannot rename over a file
        self.files[b] = self.files.pop(a)

    def ilistdir(self, path):
        self.alive()
        for name in sorted(self.files):
            yield (name, 0x8000, 0, len(self.files[name]))

    def mkdir(self, path):
        if self.step("mkdir", self._name(path)):
            raise PowerLoss()
        raise OSError(EROFS if self.fault == "erofs" else EIO)

    def rmdir(self, path):
        raise OSError(ENOENT)

    def chdir(self, path):
        pass

    def getcwd(self):
        return ""

    def statvfs(self, path):
        return (512, 512, 256, 0 if self.fault and self.fault.startswith("enospc") else 128, 128, 0, 0, 0, 0, 255)


class SyncOs:
    """store.py's `os` where the port has no os.sync (the unix ports): the real os module's
    functions, and a sync that is a step of the mounted stand-in, so every sync is counted."""

    def __init__(self, fs):
        self.fs = fs

    def __getattr__(self, name):
        return getattr(os, name)

    def sync(self):
        self.fs.sync()


def mounted(files, **kw):
    """A fresh boot's view of `files`: the stand-in mounted at MOUNT, store.py imported anew."""
    try:
        os.umount(MOUNT)
    except OSError:
        pass
    fs = Flash(files, **kw)
    os.mount(fs, MOUNT)
    sys.modules.pop("store", None)
    import store
    if not hasattr(os, "sync"):
        store.os = SyncOs(fs)
    return fs, store
