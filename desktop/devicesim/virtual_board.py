"""The unix `micropython` on a pseudo-terminal, behaving like a board to mpremote and pyserial.

    with VirtualBoard(flash_dir) as board:
        subprocess.run(["mpremote", "connect", board.port, "mip", "install", "./device/package.json"])

- Its REPL, raw REPL (Ctrl-A) included, answers on `port`, a pty a client
  opens as it would /dev/ttyACM0.
- `flash_dir` is its filesystem: the interpreter runs there, and sys.path is
  ['', FLASH/lib] (MICROPYPATH), so mpremote mip installs into FLASH/lib as it
  installs into /lib on a board.
- An exit of the interpreter is a reboot: a Ctrl-D in the raw REPL (mpremote's
  soft reset) ends the unix port, so the board prints "MPY: soft reboot",
  starts a new interpreter and puts it back in the raw REPL, as a board's
  soft reset does.

The interpreter cannot share a pty slave with a client (both would read the
same input), so it runs on an inner pty and a thread relays between that and
the outer one, the client's (port_gate.PortGate: hold_port() gives the
emulator a line of its own while clients of `port` are told it is busy).
"""

import os
import select
import subprocess
import threading
import time
import tty

from desktop.devicesim.port_gate import PortGate
from desktop.firmware.interpreters import micropython_exe, missing_hint

_CTRL_A, _CTRL_B, _CTRL_D = 0x01, 0x02, 0x04
_PROMPT = b">>> "


class VirtualBoard:
    def __init__(self, flash, exe=None):
        self.flash = os.path.abspath(flash)
        self.exe = exe or micropython_exe()
        if self.exe is None:
            raise FileNotFoundError(missing_hint("micropython"))
        os.makedirs(os.path.join(self.flash, "lib"), exist_ok=True)
        self.port = None
        self.gate = None
        self.reboots = 0
        self._proc = None
        self._raw = False
        self._soft = False      # a Ctrl-D at an empty raw REPL: the next exit is a soft reset
        self._code = False      # bytes of code typed at the raw REPL since its last Ctrl-A or Ctrl-D
        self._stop = threading.Event()
        self._thread = None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()

    def start(self):
        self._inner, inner_slave = os.openpty()
        tty.setraw(inner_slave)   # a byte pipe, no echo or newline translation: USB CDC
        self._inner_slave = inner_slave
        self.gate = PortGate()
        self.port = self.gate.port
        self._boot(first=True)
        self._thread = threading.Thread(target=self._relay, name="virtual-board", daemon=True)
        self._thread.start()
        return self

    def _spawn(self, main):
        """Start the interpreter on the inner pty: here its REPL (a board without firmware).
        main: a power-on or hard reset (False: a soft reset from the raw REPL)."""
        env = dict(os.environ, MICROPYPATH=os.path.join(self.flash, "lib"))
        s = self._inner_slave
        return subprocess.Popen([self.exe], stdin=s, stdout=s, stderr=s, cwd=self.flash, env=env)

    def _boot(self, first=False):
        soft = self._soft and not first
        self._soft = False
        if not soft:
            self._raw = False       # a power-on or hard reset leaves the raw REPL
        self._proc = self._spawn(main=not soft)
        if not soft:
            return
        # wait for the new REPL before typing: the interpreter flushes its input
        # when it sets up the terminal, so a byte sent earlier could be lost
        self._forward_until(_PROMPT, timeout=10.0)
        os.write(self._inner, bytes((_CTRL_A,)))

    def _forward_until(self, marker, timeout):
        seen = b""
        end = time.monotonic() + timeout
        while marker not in seen and time.monotonic() < end:
            r, _, _ = select.select([self._inner], [], [], 0.05)
            if r:
                data = self._read(self._inner)
                seen = (seen + data)[-256:]
                self.gate.write(data)

    @staticmethod
    def _read(fd):
        try:
            return os.read(fd, 4096)
        except OSError:   # EIO: no process holds the slave end now
            return b""

    def _relay(self):
        gate = self.gate
        while not self._stop.is_set():
            outer = gate.fds()
            r, _, _ = select.select([self._inner] + outer, [], [], 0.05)
            if self._inner in r:
                data = self._read(self._inner)
                if data:
                    gate.write(data)
            for fd in outer:
                if fd not in r:
                    continue
                data = gate.read(fd)
                for b in data:
                    if b == _CTRL_A:
                        self._raw = True
                        self._code = False
                    elif b == _CTRL_B:
                        self._raw = False
                    elif b == _CTRL_D and self._raw:
                        # ends the code typed (run it), or, with none, asks for a soft reset
                        self._soft = not self._code
                        self._code = False
                    elif self._raw and b >= 0x20:
                        self._code = True
                if data:
                    os.write(self._inner, data)
            if self._proc.poll() is not None and not self._stop.is_set():
                # drain what the interpreter said last, then reboot as a board does
                while select.select([self._inner], [], [], 0.02)[0]:
                    data = self._read(self._inner)
                    if not data:
                        break
                    gate.write(data)
                gate.write(b"MPY: soft reboot\r\n")
                self.reboots += 1
                self._boot()

    def hold_port(self, doing):
        """Clients of `port` are told the board is busy `doing`; the path of the emulator's own line."""
        return self.gate.hold(doing)

    def release_port(self):
        self.gate.release()

    def close(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()
        if self.gate is not None:
            self.gate.close()
        for fd in (getattr(self, n, None) for n in ("_inner", "_inner_slave")):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
