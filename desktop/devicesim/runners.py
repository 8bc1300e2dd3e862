"""Run the firmware on a simulated handheld: in-process (CPython) or in `micropython`.

    from desktop.devicesim.runners import start_device
    from desktop.devicesim.world import make_world
    world = make_world(serial=None, motion="hand", seconds=60, seed=1)
    dev = start_device(world, root, kind="micropython")     # or "cpython"
    dev.run_until(1.0); world.press(0.2); dev.run_until(40.0)
    dev.close()

Both kinds run the same device/ code through device/hal_sim.py. "micropython"
runs the firmware's .mpy image (desktop/firmware/image.py, the "sim"
runtime's files) in the real MicroPython unix port as a child process, its
link (device/sim_link.py) on the child's stdin/stdout, answered by
link_host.HostLink. The board's flash is the folder ROOT/flash.
"""

import os
import subprocess
import threading

from desktop.devicesim.costs import COSTS_S, costs_us
from desktop.devicesim.link_host import HostLink
from desktop.firmware.files import import_device
from desktop.firmware.image import build_image
from desktop.firmware.interpreters import interpreter as interpreter_path

HEAP = "256K"   # an rp2040 gives MicroPython ~200 KB of heap; a little slack for the sim link


def flash_dir(root):
    fs = os.path.join(root, "flash")
    os.makedirs(fs, exist_ok=True)
    return fs


def write_config(root, **settings):
    """Put a config.json on the simulated flash before boot (what a user does once per board)."""
    import_device("store").save(flash_dir(root), "config", settings)


class DeviceDied(RuntimeError):
    pass


class InProcessDevice:
    """The firmware's modules imported into this CPython process; World is the link.

    The firmware boots and runs its own main loop (App.run) in a thread that
    has the turn only while run_until waits: when it idles with the world's
    time up, the World parks it (World.on_due) and hands the turn back, as the
    pipe runner's host does with the `micropython` process; it boots during the
    first run_until, as that process does. One thread runs at a time, so the
    run is deterministic and sees the same sequence of events as the pipe
    runner's. `app` and `board` exist from the first run_until on;
    on_boot(device) runs in between, before the first conversion is serviced.
    """

    kind = "cpython"

    def __init__(self, world, root, polled=False, costs=COSTS_S, on_boot=None):
        self.world = world
        self._boot = (flash_dir(root), polled, costs_us(costs), on_boot)
        self.board = self.app = None
        self._turn = threading.Condition()
        self._firmware_has_turn = False
        self._thread = None
        self._error = None
        world.on_due = self._park

    def _park(self):
        if threading.current_thread() is not self._thread:
            return   # a test driving the board from its own thread: nothing to hand back
        with self._turn:
            self._firmware_has_turn = False
            self._turn.notify_all()
            self._turn.wait_for(lambda: self._firmware_has_turn)

    def _main(self):
        try:
            fs, polled, costs, on_boot = self._boot
            self.board = import_device("hal_sim").Board(self.world, fs, polled=polled, costs=costs)
            self.app = import_device("app").App(self.board)
            if on_boot is not None:
                on_boot(self)
            self.app.run()
        except BaseException as e:  # noqa: B036 - reported by run_until in the caller's thread
            self._error = e
        finally:
            with self._turn:
                self._firmware_has_turn = False
                self._turn.notify_all()

    def _give_turn(self):
        with self._turn:
            self._firmware_has_turn = True
            if self._thread is None:
                self._thread = threading.Thread(target=self._main, name="firmware", daemon=True)
                self._thread.start()
            else:
                self._turn.notify_all()
            self._turn.wait_for(lambda: not self._firmware_has_turn)
        if self._error is not None:
            raise DeviceDied("the firmware raised %r" % (self._error,)) from self._error

    def run_until(self, t):
        """Let the firmware run until it idles with the world at `t` s (or it stops)."""
        self.world.until = t
        if self._thread is None or self._thread.is_alive():
            self._give_turn()

    def close(self):
        if self._thread is not None and self._thread.is_alive():
            self.world.quit = True
            self._give_turn()
            self._thread.join(timeout=5)
        self.world.close()


class MicroPythonDevice:
    """The firmware's image in a MicroPython (or CircuitPython) executable, its HAL piped to the World.

    interpreter: a name of desktop/firmware/interpreters.py (the pip `micropython`
    by default); the MicroPython builds run the .mpy image, CircuitPython the
    sources (it refuses MicroPython's .mpy).
    """

    kind = "micropython"

    def __init__(self, world, root, interpreter="micropython", heap=HEAP, lock_heap_in_isr=True, polled=False,
                 costs=COSTS_S):
        exe = interpreter_path(interpreter)
        if exe is None:
            raise FileNotFoundError("no %s executable (python -m desktop.firmware.interpreters list)" % interpreter)
        self.interpreter = interpreter
        self.world = world
        self.errfile = open(os.path.join(root, "micropython.stderr"), "w+b")
        lib = build_image(os.path.join(root, "lib"), runtime="sim", compiled=not interpreter.startswith("circuitpython"))
        boot = ("import sys\nsys.path[:0] = [%r]\nimport sim_main\nsim_main.run(%r, %r, %r, %r)\n"
                % (lib, flash_dir(root), bool(lock_heap_in_isr), bool(polled), costs_us(costs)))
        self.proc = subprocess.Popen([exe, "-X", "heapsize=" + heap, "-c", boot], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.errfile, bufsize=0)
        self.link = HostLink(world, self._read, self.proc.stdin.write)

    def _read(self, n):
        buf = bytearray()
        while len(buf) < n:
            chunk = self.proc.stdout.read(n - len(buf))
            if not chunk:
                self._died()
            buf += chunk
        return bytes(buf)

    def _died(self):
        self.proc.wait(timeout=5)
        self.errfile.seek(0)
        err = self.errfile.read().decode(errors="replace").strip()
        raise DeviceDied("micropython exited (%s): %s" % (self.proc.returncode, err[-2000:]))

    @property
    def messages(self):
        return self.link.messages

    def run_until(self, t):
        self.link.serve(t)

    def close(self):
        if self.proc.poll() is None:
            try:
                self.link.quit()
                self.proc.stdin.close()
            except (BrokenPipeError, OSError):
                pass
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.errfile.close()
        self.world.close()


def start_device(world, root, kind="micropython", **kw):
    """A running device: kind "cpython" (in-process) or an interpreter's name
    ("micropython", "micropython-float32", "micropython-reprc", "circuitpython")."""
    os.makedirs(root, exist_ok=True)
    if kind == "cpython":
        return InProcessDevice(world, root, **kw)
    return MicroPythonDevice(world, root, interpreter=kind, **kw)
