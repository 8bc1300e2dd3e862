# Put a staged firmware in place by renames. Not a module of the desktop package: run on a
# MicroPython board by `mpremote run` (in its current folder, the filesystem's root), and on
# a CircuitPython drive's folder by desktop/firmware/deploy.py (swap(folder), in CPython);
# so it uses only what both have (os.listdir, stat, rename, mkdir, remove, rmdir; "/" paths).
#
# deploy copies the new firmware into .fluxcal-new/ first, laid out as it belongs (lib/...,
# main.py). Only once every file is there does this run: each file it replaces goes into
# .fluxcal-old/, the new one takes its place, and if any rename fails every rename done is
# undone. Renames need no free space, so a full flash stops a deploy while it copies, with
# the previous firmware untouched, never half way through the swap. A file the new firmware
# no longer has (a native module of another arch) is named in the stage's .fluxcal-remove, one
# path a line: it goes into .fluxcal-old/ as a replaced file does, and comes back on an undo.
import os

NEW = ".fluxcal-new"
OLD = ".fluxcal-old"
REMOVE = ".fluxcal-remove"
_DIR = 0x4000   # S_IFDIR in st_mode


def _mode(path):
    """st_mode of path, 0 when there is nothing there."""
    try:
        return os.stat(path)[0]
    except OSError:
        return 0


def _isdir(path):
    return _mode(path) & _DIR != 0


def _files(top, rel=""):
    """Paths of the files under top, relative to it, "/"-separated."""
    out = []
    here = top + "/" + rel if rel else top
    for name in sorted(os.listdir(here)):
        sub = rel + "/" + name if rel else name
        if _isdir(here + "/" + name):
            out += _files(top, sub)
        else:
            out.append(sub)
    return out


def _mkdirs(path):
    done = "/" if path.startswith("/") else ""
    for part in path.split("/"):
        if part:
            done = done + part if done in ("", "/") else done + "/" + part
            if not _isdir(done):
                os.mkdir(done)


def _parent(path):
    return path[:path.rfind("/")] if "/" in path else ""


def rmtree(path):
    if _isdir(path):
        for name in os.listdir(path):
            rmtree(path + "/" + name)
        os.rmdir(path)
    elif _mode(path):
        os.remove(path)


def _replaced(rel):
    """What a new file takes the place of: itself and, under lib/, its other form. MicroPython
    imports x.py before x.mpy, so a stale x.py would shadow a new x.mpy."""
    if rel.startswith("lib/") and rel.endswith(".mpy"):
        return [rel, rel[:-4] + ".py"]
    if rel.startswith("lib/") and rel.endswith(".py"):
        return [rel, rel[:-3] + ".mpy"]
    return [rel]


def swap(root=""):
    """Move every file staged under root/.fluxcal-new into place; returns how many."""
    def at(rel):
        return root + "/" + rel if root else rel

    files = [rel for rel in _files(at(NEW)) if rel != REMOVE]
    if not files:
        raise OSError("nothing staged in " + at(NEW))
    gone = []
    if _mode(at(NEW + "/" + REMOVE)):
        with open(at(NEW + "/" + REMOVE)) as fh:
            gone = [line.strip() for line in fh.read().split("\n") if line.strip()]
    rmtree(at(OLD))
    done = []   # (from, to) of each rename, to undo them

    def set_aside(old):
        if _mode(at(old)):
            _mkdirs(at(OLD + "/" + _parent(old)))
            os.rename(at(old), at(OLD + "/" + old))
            done.append((at(old), at(OLD + "/" + old)))

    try:
        for old in gone:
            set_aside(old)
        for rel in files:
            for old in _replaced(rel):
                set_aside(old)
            if _parent(rel):
                _mkdirs(at(_parent(rel)))
            os.rename(at(NEW + "/" + rel), at(rel))
            done.append((at(NEW + "/" + rel), at(rel)))
    except BaseException:
        for src, dst in reversed(done):
            os.rename(dst, src)
        rmtree(at(OLD))   # only the folders made for the moved files are left there
        raise
    rmtree(at(OLD))
    rmtree(at(NEW))
    return len(files)


if __name__ == "__main__":   # mpremote run
    print("fluxcal-swap", swap())
