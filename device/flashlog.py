"""The survey's rotating CSV log on the board's flash (config `log`): survey.py's Output writes a
line per block while no calibration is in progress.

    log = RotatingLog(root, file_bytes, files, reserve)
    log.write(b"t_ms,...\n")    # a line's bytes; False once it stopped: .error says why (log_full, log_error)
    log.close()
"""

import os

from store import file_path, free_bytes


class RotatingLog:
    """Append lines to root/log0.csv .. log{files-1}.csv, oldest overwritten.

    Never fills the filesystem: before a file is (re)started the free space
    must exceed file_bytes + reserve, otherwise logging stops with a reason.
    """

    HEADER = b"t_ms,x_nt,y_nt,z_nt,f_nt,temp_c\n"   # lines are bytes (survey.py's one format each)

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
        return free_bytes(self.root)

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
        self.f = open(name, "wb")
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
