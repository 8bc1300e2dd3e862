"""The virtual handheld: a virtual board with the simulated fluxgate and its two ADS1292, live.

    with VirtualHandheld(flash_dir, runtime="micropython") as hh:
        print(hh.port)              # /dev/pts/N: mpremote, pyserial and fluxcal use it as a board
        hh.act("press")             # the operator: press, long-press, hand, hold, spin, power-cycle

The board is virtual_board.VirtualBoard (the interpreter on a pseudo-terminal, its
REPL and raw REPL relayed, a folder as its flash, an exit a reboot) with the
stand-ins for the board's C modules on its path (stand-ins/, simboard.py's wiring),
so that power-up runs boot.py and main.py (code.py on CircuitPython) from the
flash through the board's own HAL (device/hal_micropython.py,
device/hal_circuitpython.py), as on a board. Its SPI and pins reach the World,
whose handheld is live (desktop/sim/handheld.py with desktop/sim/operator.py's
LiveOperator: the operator's motion is decided as time goes), and simulated time
follows the wall clock (realtime.Pacer). A soft reset from the raw REPL (mpremote)
runs boot.py only; a hard reset (machine.reset, `mpremote reset`) or a power
cycle runs main.py again.

The operator follows the LED unless told otherwise (`act`): it turns the sensor
while the LED says "collecting" or "enough", and holds still otherwise, as the
manual says (docs/firmware.md, Operation), so `fluxcal calibrate` works with no
one at the keyboard. World time runs only while the firmware runs: at the REPL
nothing needs it.
"""

import os
import queue
import subprocess
import threading
import time

import numpy as np

from desktop.devicesim.link_host import HostLink
from desktop.devicesim.procedure import handheld_config
from desktop.devicesim.realtime import Pacer
from desktop.devicesim.runners import board_env, board_rom, heap_for
from desktop.devicesim.virtual_board import VirtualBoard
from desktop.devicesim.world import World
from desktop.firmware.interpreters import interpreter, missing_hint
from desktop.sim.handheld import Handheld
from desktop.sim.operator import LiveOperator
from desktop.sim.scenario import Scenario

RUNTIMES = ("micropython", "micropython-float32", "micropython-reprc", "circuitpython")
ACTIONS = ("hand", "hold", "spin", "follow", "press", "long-press", "power-cycle", "field-step", "walk")
_LONG_S = 2.0        # a long press (cancel: 1.5 s in device/button.py)


def led_says_turn(led_log, now):
    """Does the LED, read as a person reads it, say "keep turning"? Its edges in the last
    second: "collecting" blinks at 2 Hz (4 edges), "enough" flickers (~13); survey,
    uncalibrated and done change at most once or twice, a fault 20 times (docs/firmware.md)."""
    edges = 0
    for t, _level in reversed(led_log):
        if t < now - 1.0:
            break
        edges += 1
    return 3 <= edges <= 16


def live_world(sensor="mag649", seed=0, motion_seed=1, serial=None, survey=None):
    """A World on a live handheld (its operator decides as time goes), and that operator; with
    `survey` (Scenario's survey settings: the grid, the site) a surveyor on that site (walker.py)."""
    if survey is not None:
        from desktop.devicesim.walker import Walker
        sc = Scenario(sensor=sensor, seed=seed, motion_seed=motion_seed, motion="survey", survey=survey, rate=1000)
        operator = Walker(sc.walk())
        return World(Handheld(sc, operator=operator, batch=512), serial=serial), operator
    sc = Scenario(sensor=sensor, seed=seed, motion_seed=motion_seed, motion="stationary", seconds=1.0, rate=1000)
    operator = LiveOperator(np.random.default_rng(motion_seed), mode="hold")
    return World(Handheld(sc, operator=operator, batch=512), serial=serial), operator


class Hands:
    """The operator's hands on a live World: queued actions, done between two slices of
    simulated time, and, unless told otherwise, following the LED."""

    def __init__(self, world, operator):
        self.world = world
        self.operator = operator
        self.following = not hasattr(operator, "begin")     # a surveyor walks, it does not follow the LED
        self.field_steps = []       # (chip time the step happens, nT, wall time it was asked for)
        self.steps_reached = []     # wall time at which simulated time reached each field step
        self._actions = queue.Queue()

    def act(self, action, arg=None):
        if action not in ACTIONS:
            raise ValueError("unknown action %r (one of %s)" % (action, ", ".join(ACTIONS)))
        surveyor = hasattr(self.operator, "begin")
        if action == "walk" and not surveyor:
            raise ValueError("walk needs a site to walk: fluxcal emulate --survey WxL")
        if surveyor and action in ("hand", "hold", "spin", "follow"):
            raise ValueError("the surveyor walks the grid (walk); %s is the calibration's operator's" % action)
        self._actions.put((action, arg))

    def step(self):
        w = self.world
        while True:
            try:
                action, arg = self._actions.get_nowait()
            except queue.Empty:
                break
            if action in ("hand", "hold", "spin"):
                self.following = False
                self.operator.set(action, w.time)
            elif action == "follow":
                self.following = True
            elif action == "press":
                w.press(float(arg) if arg else 0.2)
            elif action == "long-press":
                w.press(_LONG_S)
            elif action == "walk":
                t0 = w.handheld.t0
                for down, up in self.operator.begin(w.time - t0):
                    w.press(up - down, at=t0 + down)
            elif action == "field-step":
                self.field_steps.append((w.handheld.step_field(float(arg) if arg else 100.0), arg, time.monotonic()))
        if len(self.steps_reached) < len(self.field_steps) and w.time >= self.field_steps[len(self.steps_reached)][0]:
            self.steps_reached.append(time.monotonic())
        if self.following:
            self.operator.set("hand" if led_says_turn(w.led_log, w.time) else "hold", w.time)


class VirtualHandheld(VirtualBoard):
    def __init__(self, flash, runtime="micropython", sensor="mag649", seed=0, motion_seed=1, heap=None,
                 speed=1.0, on_behind=None, survey=None):
        if runtime not in RUNTIMES:
            raise ValueError("unknown runtime %r (one of %s)" % (runtime, ", ".join(RUNTIMES)))
        exe = interpreter(runtime)
        if exe is None:
            raise FileNotFoundError(missing_hint(runtime))
        super().__init__(flash, exe=exe)
        self.runtime = "circuitpython" if runtime == "circuitpython" else "micropython"
        self.heap = heap_for(runtime, heap)
        self.speed = speed
        self.on_behind = on_behind
        self.world, self.operator = live_world(sensor, seed, motion_seed, survey=survey)
        self.scenario = self.world.scenario
        self.hands = Hands(self.world, self.operator)
        self.pacer = None
        self._rom = board_rom(os.path.join(self.flash, "..", os.path.basename(self.flash) + ".rom"), self.runtime)
        self._link_thread = None
        self._link_stop = threading.Event()
        self._fds = ()

    def wiring_config(self):
        """The config.json a user writes once for this board (docs/firmware.md, Configuration):
        the front end's nT per code, and on CircuitPython the pins by their board names."""
        return handheld_config(self.scenario, "board:" + self.runtime)

    # ****** the operator ******
    def act(self, action, arg=None):
        """What the operator does (ACTIONS), at the next slice of simulated time."""
        if action == "power-cycle":
            self.power_cycle()
        else:
            self.hands.act(action, arg)

    def power_cycle(self):
        """Switch it off and on: the interpreter dies where it is and boots again."""
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()

    # ****** the board: an interpreter per boot, its link served in real time ******
    def _spawn(self, main):
        self._stop_link()
        to_fw, to_fw_w = os.pipe()
        from_fw_r, from_fw = os.pipe()
        program = "import simboard\nsimboard.power_on(%r, main=%r)\n" % (self.runtime, bool(main))
        s = self._inner_slave
        proc = subprocess.Popen([self.exe, "-X", "heapsize=" + self.heap, "-i", "-c", program],
                                stdin=s, stdout=s, stderr=s, cwd=self.flash,
                                env=board_env(self._rom, self.flash, (to_fw, from_fw)), pass_fds=(to_fw, from_fw))
        os.close(to_fw)
        os.close(from_fw)
        self._fds = (to_fw_w, from_fw_r)
        link = HostLink(self.world, lambda n: self._read_link(from_fw_r, n), lambda d: os.write(to_fw_w, d))
        self.pacer = Pacer(link.serve, lambda: self.world.time, speed=self.speed, on_step=self.hands.step,
                           on_behind=self.on_behind)
        self._link_stop = threading.Event()
        self._link_thread = threading.Thread(target=self._serve, args=(self.pacer, self._link_stop),
                                             name="virtual-handheld-link", daemon=True)
        self._link_thread.start()
        return proc

    @staticmethod
    def _read_link(fd, n):
        buf = bytearray()
        while len(buf) < n:
            chunk = os.read(fd, n - len(buf))
            if not chunk:
                raise EOFError("the board's interpreter stopped")
            buf += chunk
        return bytes(buf)

    @staticmethod
    def _serve(pacer, stop):
        try:
            pacer.run(stop)
        except (EOFError, OSError):
            pass        # the interpreter ended (a reset, a power cycle): the next boot serves anew

    def _stop_link(self):
        self._link_stop.set()
        for fd in self._fds:
            try:
                os.close(fd)
            except OSError:
                pass
        self._fds = ()
        if self._link_thread is not None:
            self._link_thread.join(timeout=5)
            self._link_thread = None

    def close(self):
        super().close()
        self._stop_link()


class InProcessHandheld:
    """The same live handheld with the firmware in this CPython process (device/sim/hal_sim.py), its
    serial on the World's pty: no REPL and no deploying, for working on the protocol fast."""

    def __init__(self, root, sensor="mag649", seed=0, motion_seed=1, speed=1.0, on_behind=None, survey=None):
        self.world, self.operator = live_world(sensor, seed, motion_seed, serial="pty", survey=survey)
        self.scenario = self.world.scenario
        self.hands = Hands(self.world, self.operator)
        self.port = self.world.serial_port
        self.root = root
        self.speed = speed
        self.on_behind = on_behind
        self.pacer = None
        self._dev = None
        self._stop = threading.Event()
        self._thread = None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()

    def start(self):
        from desktop.devicesim.runners import start_device
        self._dev = start_device(self.world, self.root, kind="cpython")
        self.pacer = Pacer(self._dev.run_until, lambda: self.world.time, speed=self.speed,
                           on_step=self.hands.step, on_behind=self.on_behind)
        self._thread = threading.Thread(target=self.pacer.run, args=(self._stop,), name="in-process-handheld",
                                        daemon=True)
        self._thread.start()
        return self

    def act(self, action, arg=None):
        if action == "power-cycle":
            raise ValueError("the in-process firmware has no power switch: use a --runtime with a board")
        self.hands.act(action, arg)

    def close(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        if self._dev is not None:
            self._dev.close()
