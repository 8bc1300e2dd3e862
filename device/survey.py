"""Survey output: block averages at survey_hz, corrected to nT, and a rotating flash log.

    sv = Survey(cfg, window, decim_rate_hz)
    rec = sv.sample(sx, sy, sz, st, f)   # None, or a finished block (a tuple)

A block over 1/survey_hz (0.1 s at the default 10 Hz, the paper's moving
average width, IV.C) averages |h_c| of every decimated sample -- rotation
invariant -- and, separately, the raw vector (integer sums). Averaging the
vectors and taking |.| afterwards would shrink |B| by ~B (w T)^2/24 while the
operator turns: 769 nT at 1 rev/s over 0.1 s (docs/simulator.md, smearing).
"""

import os

from store import file_path


class Survey:
    def __init__(self, cfg, window, sample_hz):
        self.window = window
        self.per_block = max(1, int(sample_hz / cfg["survey_hz"] + 0.5))
        self.blocks = 0
        self.restart()

    def restart(self):
        """Drop the open block (its samples were taken without |h_c|)."""
        self._n = 0
        self._sx = self._sy = self._sz = self._st = 0
        self._f = 0.0

    def sample(self, sx, sy, sz, st, f):
        """Accumulate; at the end of a block return (x, y, z, t) mean codes and mean |h_c|."""
        self._sx += sx
        self._sy += sy
        self._sz += sz
        self._st += st
        self._f += f
        self._n += 1
        if self._n < self.per_block:
            return None
        d = float(self._n * self.window)
        out = (self._sx / d, self._sy / d, self._sz / d, self._st / d, self._f / self._n)
        self._n = 0
        self._sx = self._sy = self._sz = self._st = 0
        self._f = 0.0
        self.blocks += 1
        return out


class RotatingLog:
    """Append lines to root/log0.csv .. log{files-1}.csv, oldest overwritten.

    Never fills the filesystem: before a file is (re)started the free space
    must exceed file_bytes + reserve, otherwise logging stops with a reason.
    """

    HEADER = "t_ms,x_nt,y_nt,z_nt,f_nt,temp_c\n"

    def __init__(self, root, file_bytes, files, reserve):
        self.root = root
        self.file_bytes = file_bytes
        self.files = files
        self.reserve = reserve
        self.index = 0
        self.size = 0
        self.f = None
        self.error = None
        self.lines = 0
        self._since_flush = 0
        # continue after the newest existing file rather than overwrite it
        newest = -1
        best = -1
        for i in range(files):
            try:
                m = os.stat(self._name(i))[8]
            except OSError:
                continue
            if m >= best:
                best, newest = m, i
        self.index = (newest + 1) % files

    def _name(self, i):
        return file_path(self.root, "log%d.csv" % i)

    def free_bytes(self):
        try:
            s = os.statvfs(self.root or ".")
            return s[0] * s[4]   # f_bsize * f_bavail
        except (OSError, AttributeError):
            return None

    def _open_next(self):
        self.close()
        name = self._name(self.index)
        try:
            os.remove(name)
        except OSError:
            pass
        free = self.free_bytes()
        if free is not None and free < self.file_bytes + self.reserve:
            self.error = "log_full: %d bytes free, need %d" % (free, self.file_bytes + self.reserve)
            return False
        self.f = open(name, "w")
        self.f.write(self.HEADER)
        self.size = len(self.HEADER)
        self.index = (self.index + 1) % self.files
        return True

    def write(self, line):
        if self.error:
            return False
        try:
            if self.f is None or self.size + len(line) > self.file_bytes:
                if not self._open_next():
                    return False
            self.f.write(line)
            self.size += len(line)
            self.lines += 1
            self._since_flush += 1
            if self._since_flush >= 50:
                self.f.flush()
                self._since_flush = 0
        except OSError as e:
            self.error = "log_error: %s" % e
            self.close()
            return False
        return True

    def close(self):
        if self.f is not None:
            try:
                self.f.close()
            except OSError:
                pass
            self.f = None
