"""The emulated Raspberry Pi Pico on a pseudo-terminal: MicroPython's own rp2 firmware in rp2040js.

    with PicoBoard("out/pico.flash", idle="jump") as board:
        subprocess.run(["mpremote", "connect", board.port, "exec", "print(1)"])
        board.power_cycle()             # the chip re-created; the flash file keeps its files

The runner (desktop/devicesim/pico/runner.mjs) is a Node child in a process group of its own:
its stdin and stdout are the board's USB CDC, its stderr one line per event ("pico: boot
(watchdog)"). A thread here relays between them and a pty whose slave a client opens as it
opens /dev/ttyACM0. Why a pty held here rather than socat on a TCP port (the route
../shared/rp2/SOURCE.md measured): one process fewer to leave behind, no TCP port to pick,
and the relay sees when the runner ends, so it can hang up the port as an unplugged board does.
hold_port() gives the emulator a line of its own while clients of `port` are told the board is
busy (port_gate.PortGate: `fluxcal emulate` deploying and starting its firmware).
close() (and the interpreter's exit) ends the whole process group; the runner saves the flash
file on SIGTERM and on EOF of its stdin, so it also saves when this process dies.

idle: "paced" spends the firmware's idle time as wall time (a person at the keyboard, mpremote's
1 s polls); "jump" skips it to the next timer (tests and benches: the emulated clock is the
only clock the firmware sees either way).
"""

import atexit
import json
import os
import select
import signal
import subprocess
import threading
import time

from desktop.devicesim.port_gate import PortGate
from desktop.firmware.interpreters import pico_parts

RUNNER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pico", "runner.mjs")
BUTTON_PIN = 15       # device/config.py: the button, active low; pull-ups are not modelled


class PicoError(RuntimeError):
    pass


class PicoBoard:
    def __init__(self, flash_file, idle="paced", high=(BUTTON_PIN,), world=None, log=None, frozen=False):
        self.parts = pico_parts(frozen=frozen)     # frozen: the image with the firmware frozen in
        if self.parts is None:
            raise FileNotFoundError("%s is not built: make interpreters" % ("rp2-pico-frozen" if frozen else "rp2-pico"))
        if idle not in ("paced", "jump"):
            raise ValueError("idle is 'paced' or 'jump', not %r" % (idle,))
        self.flash_file = os.path.abspath(flash_file)
        self.idle = idle
        self.high = tuple(high)
        self.log = log
        self.world = world            # a pico_world.PinWorld on the pins, or None (nothing wired)
        self.port = None
        self.proc = None
        self.events = []              # the runner's event lines, "pico: " cut off
        self._changed = threading.Condition()
        self._thread = None
        self.gate = None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()

    def start(self):
        # what the board sends while no client reads is dropped rather than stalling the board
        # (a host that does not read a CDC port loses its bytes)
        self.gate = PortGate(drop_when_full=True)
        self.port = self.gate.port
        cmd = ["node", RUNNER, "--modules", self.parts["node_modules"], "--firmware", self.parts["firmware"],
               "--bootrom", self.parts["bootrom"], "--flash", self.flash_file, "--idle", self.idle,
               "--high", ",".join(str(p) for p in self.high)]
        fds = ()
        if self.world is not None:
            to_runner_r, to_runner = os.pipe()
            from_runner, from_runner_w = os.pipe()
            fds = (to_runner_r, from_runner_w)
            cmd += ["--world", "%d,%d" % fds]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     start_new_session=True, pass_fds=fds)
        atexit.register(self.close)
        if self.world is not None:
            for fd in fds:
                os.close(fd)
            self._world_thread = threading.Thread(target=self._serve_world, args=(from_runner, to_runner),
                                                  name="pico-world", daemon=True)
            self._world_thread.start()
        self._thread = threading.Thread(target=self._relay, name="pico-relay", daemon=True)
        self._thread.start()
        return self

    # ****** the relay: pty <-> the runner's stdin/stdout; its stderr -> events ******
    def _relay(self):
        out, err = self.proc.stdout.fileno(), self.proc.stderr.fileno()
        watched = [out, err]
        partial = b""
        gate = self.gate
        while out in watched:
            ports = gate.fds()
            try:
                ready, _, _ = select.select(watched + ports, [], [], 0.2)
            except (OSError, ValueError):
                break                 # closed under us by close()
            for fd in ports:
                data = gate.read(fd) if fd in ready else b""
                if data:
                    try:
                        self.proc.stdin.write(data)
                        self.proc.stdin.flush()
                    except (OSError, ValueError):
                        pass          # the runner is gone; its end is seen on its stdout
            if out in ready:
                data = _read(out)
                if data:
                    gate.write(data)
                else:
                    watched.remove(out)
            if err in ready:
                data = _read(err)
                if not data:
                    watched.remove(err)
                partial += data
                *lines, partial = partial.split(b"\n")
                for line in lines:
                    self._event(line.decode(errors="replace"))
        self._event("stopped (exit %s)" % self.proc.wait())
        self._hang_up()

    def _serve_world(self, from_runner, to_runner):
        with os.fdopen(from_runner, "rb", buffering=65536) as r, os.fdopen(to_runner, "wb", buffering=0) as w:
            try:
                self.world.serve(r.read, w.write)
            except (BrokenPipeError, OSError):
                pass              # the runner ended (close, a kill): its events say so

    def _event(self, line):
        line = line[len("pico: "):] if line.startswith("pico: ") else line
        with self._changed:
            self.events.append(line)
            self._changed.notify_all()
        if self.log is not None:
            self.log(line)

    def wait_event(self, text, timeout=60.0, after=0):
        """The first event line (from index `after`) containing text; PicoError after timeout s."""
        end = time.monotonic() + timeout
        with self._changed:
            while True:
                for line in self.events[after:]:
                    if text in line:
                        return line
                left = end - time.monotonic()
                if left <= 0:
                    raise PicoError("the emulated Pico did not say %r in %.0f s (said: %s)"
                                    % (text, timeout, "; ".join(self.events[-3:])))
                self._changed.wait(left)

    def _hang_up(self):
        """The runner ended: close the port's ends, so a client reading it gets an error
        at once (as when a board is unplugged) instead of waiting for its deadline."""
        if self.gate is not None:
            self.gate.close()

    def hold_port(self, doing):
        """Clients of `port` are told the board is busy `doing`; the path of the emulator's own line."""
        return self.gate.hold(doing)

    def release_port(self):
        self.gate.release()

    # ****** the power switch ******
    def power_cycle(self):
        """Off and on: the chip is re-created from the flash file's contents."""
        self.proc.send_signal(signal.SIGUSR2)

    def figures(self, timeout=10.0):
        """The runner's counts now, a dict: ns (emulated since power-on), asleep_ns (of which the
        core slept: cycles awake = (ns - asleep_ns) / 8 at 125 MHz), wall_ms, parts (the awake
        cycles and calls by part, pico/parts.mjs), bridge (pins.mjs's; its latencyMaxNs is the
        worst since the last call)."""
        n = len(self.events)
        self.proc.send_signal(signal.SIGUSR1)
        return json.loads(self.wait_event("figures ", timeout=timeout, after=n).split(" ", 1)[1])

    def running(self):
        return self.proc is not None and self.proc.poll() is None

    def close(self):
        """End the runner and everything in its process group (it saves the flash first)."""
        atexit.unregister(self.close)
        if self.proc is not None and self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGTERM)
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
            except ProcessLookupError:
                pass
        for thread in (self._thread, getattr(self, "_world_thread", None)):
            if thread is not None:
                thread.join(timeout=5)
        self._hang_up()


def _read(fd):
    try:
        return os.read(fd, 4096)
    except OSError:               # EIO: the other end is closed
        return b""
