"""The application: the owners wired together, and the main loop.

    App(board).run()      # main.py / code.py / the simulators all end here

The owners, each with its own job and its own part of `status` (commands.py merges them):
- acquisition.Acquisition: the DRDY handler's boxcar and the ring it fills;
- health.AdcSupervisor: the ADS1292 pair started, watched, faulted and re-probed;
- survey.Output: every decimated sample through the spike screen into a calibration
  session and the survey (|h_c|, temperature compensation, data events, the log);
- calibration_flow.CalibrationFlow: the calibration in force and the session
  (start, finish, cancel, install, clear) the button and the commands share;
- bootguard.Guard: the main loop's errors and safe mode;
- protocol.Protocol with commands.TABLE, button.Button, led.Led.
A sample goes from the ring straight to Output.sample (bound once), and from
there to the session's gates and the survey: it never comes back here.

One cooperative main loop, no threads: drain the DRDY ring, poll the button and
the serial line, drive the LED, then idle for _HOUSE_MS. The DRDY handler does
the boxcar itself and the ring holds 1.28 s of samples, so a pass runs every
_HOUSE_MS whatever the rates: the button, serial and LED work of a pass (~35k
instructions on a Cortex-M, docs/firmware.md) is paid 50 times a second, not
once per sample. Where an interrupt times the button's closings (MicroPython:
hal button_edge) and no bytes came, a pass sleeps until the button's or the LED's next
due time, at most _IDLE_MS: about 25 passes a second, the firmware less busy on the
emulated Pico (docs/benchmarks.md); a press counts from its closing. The raw stream keeps 20 ms.

Frames: where MicroPython has no Python stack (the rp2 port), a call whose state (locals and
value stack, a word each; two more per active try) passes 11 words takes its frame from the heap
(py/objfun.c VM_MAX_STATE_ON_STACK), a gc_alloc of several blocks and a gc_free a call; gc_alloc
searches first fit from a hint that only one-block allocations move up, so on this firmware's
fragmented heap the search is the cost. step() must stay within 11 words: at 14 (b838a2e,
reverted) its frame lived on the heap through the whole pass, the samples' allocations made
inside it, and gc_alloc took 1.2 -> 13.9 M cycles a second in survey on the emulated Pico, the
firmware 17.2 -> 23.6 % calibrating and 8.4 -> 18.4 % in survey (three unused locals added to
this step() do the same). tests/test_frames.py holds step() and what it calls every pass to
11 words; Protocol.poll, Led.update, Health.check and hal_micropython's serial_read keep their
usual path (nothing waiting, nothing due) in a small frame and call a method for the rest: with
them on the heap the serial line cost 13.8 k cycles a pass calibrating (profiled), 6.9 k now;
the firmware 5.1 -> 4.9 % in survey (docs/benchmarks.md).

Nothing stops the loop (docs/reliability.md): an exception in a pass is
counted, reported and survived (bootguard.py); ADC faults after boot are named
and re-probed until they clear (health.py); samples that cannot be the field
are screened out (screen.py); boots that never become healthy bring the next
one up in safe mode (bootguard.py).
"""

import session_modules

# ruff: noqa: E402 (the firmware's imports come after this)
# first, into an empty heap: every name the firmware interns, side by side (session_modules.py)
session_modules.intern_names()

import gc

import bootguard
import commands
import config as cfgmod
import store
from acquisition import Acquisition
from bootguard import Guard
from button import Button
from calibration_flow import CalibrationFlow
from health import AdcSupervisor
from led import Led
from protocol import VERSION, Protocol
from survey import Output

FIRMWARE_VERSION = "0.1.0"
_DRAIN = 16      # samples per loop pass at least (more when more arrive per pass)
_HOUSE_MS = 20   # a pass every 20 ms: button (debounce is 30 ms), serial, LED, samples
_IDLE_MS = 40    # or up to 40 ms where an interrupt times the button and nothing is due sooner (wait)
# board.busy keys: the main loop's work, charged as simulated time by the simulated board
_SAMPLE_CAL = "sample_cal"
_SAMPLE = "sample"
# The solver's float kernels (linalgc.mpy: 16.8 KB of code on an RP2040, resident once loaded) are taken only
# where this much heap is free as the app is built: the frozen image on a Pico (its bytecode in flash). Not the
# .mpy firmware there (137 KB free here once collected, a session's ~42 KB of bytecode still to come; its quick
# finishes already find little room, docs/limits.md), nor a 100 KB heap (~60 KB here), where the frozen image
# calibrates without them and not with them (python -m desktop.bench.heap_pico --frozen --kb 100).
_KERNELS_FREE = 150 * 1024


def float_kernels():
    """ "native" where the solver's float kernels are loaded (now, at boot: rp2 keeps every load of a native
    module, py/persistentcode.c), else "python". Only with the room above, counted before a collection (one
    here moves where the boot's and the sessions' blocks land); a session installs them (shared/linalg_native.py),
    which never imports them itself."""
    if hasattr(gc, "mem_free") and gc.mem_free() < _KERNELS_FREE:
        return "python"
    try:   # kind() is None where the interpreter's floats are not its own
        return "python" if __import__("linalgc").kind() is None else "native"
    except (ImportError, ValueError):   # ValueError: a .mpy of another arch or version
        return "python"


class App:
    firmware = FIRMWARE_VERSION

    def __init__(self, board):
        self.board = board
        self.proto = proto = Protocol(board, commands.TABLE, self)
        self.button = Button(board)
        self.led = led = Led(board)
        self.quit = False
        self.recorder = None      # a survey being recorded (`survey start`: surveylog.py, imported then)
        self.watchdog_ms = None   # the watchdog's timeout once run() started one
        self.guard = Guard(board, proto)   # counts this boot: safe mode if the last ones never became healthy
        body, _src, problem = store.load(board.root, "config")
        self.cfg, self.config_problems = cfgmod.from_dict(body if body is not None else {})
        if problem:
            self.config_problems.append(problem)
        self.output = Output(board, proto)
        self.output.stream = self.cfg["stream"]
        self.acq = acq = Acquisition(board, self.cfg["decim"], self.cfg["window"])
        self.supervisor = sup = AdcSupervisor(board, proto, led, acq)
        self.flow = flow = CalibrationFlow(board, proto, led, self.output, self.guard, sup, FIRMWARE_VERSION)
        flow.linalg_path = float_kernels()
        self.guard.flow = flow            # a loop error ends a session; safe mode drops the calibration
        sup.flow = flow                   # a fault ends a session
        sup.on_cleared = self._setup_pipeline
        # bound once: no allocation per loop pass
        self._sample_cb = self.output.sample
        self._gap_cb = self.output.gap
        flow.service = self._service
        flow.load()
        sup.start(self.cfg)
        self.output.adc = sup.adc
        self.output.acq = acq   # its block numbers number the raw stream's samples
        self._setup_pipeline()
        proto.event("boot", {"fw": FIRMWARE_VERSION, "proto": VERSION, "calibrated": flow.cal is not None,
                             "cal_source": flow.cal_source, "fault": sup.fault, "safe_mode": self.guard.safe_mode})

    def _setup_pipeline(self):
        """Every owner set up for the configuration in force (at boot, after `config set`, once
        a fault clears)."""
        c = self.cfg
        if (c["decim"], c["window"]) != (self.acq.decim, self.acq.window):
            self.acq.set_decimation(c["decim"], c["window"])   # counters from zero: a new boxcar
        self.supervisor.rate_changed(c["rate"], self.board.ticks_ms())
        self._house_idles = max(1, c["rate"] * _HOUSE_MS // 1000)
        # twice what a pass brings: a pass that ran late catches up in the next
        self._drain = max(_DRAIN, 2 * (self._house_idles // c["decim"] + 1))
        self.flow.configure(c)
        self.output.configure(c, c["rate"] / c["decim"])
        if not self.supervisor.fault:
            self.flow.steady_led()

    def apply_config(self, new):
        """Make a validated configuration current: saved first, then applied."""
        store.save(self.board.root, "config", cfgmod.changed(new))
        old = self.cfg
        self.cfg = new
        if new["stream"] != old["stream"]:
            self.output.stream = new["stream"]
        if new["rate"] != old["rate"] or (new["gain_x"], new["gain_y"], new["gain_z"]) != \
                (old["gain_x"], old["gain_y"], old["gain_z"]):
            self.supervisor.start(new)
        self._setup_pipeline()

    # ****** main loop ******
    def run(self):
        b = self.board
        guard = self.guard
        # a board with a watchdog: a pass that never comes back resets it (hal.py, bootguard.py)
        self.watchdog_ms = self.cfg["watchdog_ms"] if b.watchdog_start(self.cfg["watchdog_ms"]) else None
        feed = b.watchdog_feed
        while not self.quit and not b.quit_requested():
            try:
                self.step()
                guard.passed()
            except Exception as e:  # noqa: BLE001 - nothing stops the instrument (docs/reliability.md)
                guard.loop_error(e)
            feed()
            self.wait()
        self.output.close()
        if self.recorder is not None:
            self.recorder.stop()
        if self.quit:   # `repl`: the loop ended as asked (a deploy follows), not a crash or a hang
            guard.finished()
        b.hand_back()   # `repl` (self.quit): main.py / code.py ends next, the REPL takes the line

    def step(self):
        b = self.board
        sup = self.supervisor
        flow = self.flow
        if not sup.fault or sup.verifying:
            n = self.acq.poll(self._sample_cb, self._drain, self._gap_cb)
            if n:
                b.busy(_SAMPLE_CAL if flow.session is not None else _SAMPLE, n)
        sup.check(b.ticks_ms())
        ev = self.button.poll()
        if ev is not None:
            if self.recorder is not None:
                self.recorder.press(ev)     # recording a survey: a short press marks a line end
            else:
                flow.press(ev)
        self.proto.poll()
        if flow.session is not None:
            flow.tick()
        self.led.update()

    def _service(self):
        """The DRDY ring drained and the watchdog fed from inside a long step (the finish's solves
        and statistics, calibration_flow.py): its blocks would overflow the ring, its seconds the
        watchdog. All of the ring, not a pass's share: the next long step follows at once."""
        sup = self.supervisor
        if not sup.fault or sup.verifying:
            n = self.acq.poll(self._sample_cb, self.acq.ring_frames, self._gap_cb)
            if n:
                self.board.busy(_SAMPLE, n)
        self.board.watchdog_feed()

    def wait(self):
        """Idle for _HOUSE_MS: asleep where the DRDY handler is an interrupt, else counted in conversions.

        On MicroPython (sleeps_with_irq) the pass sleeps in sleep_ms, up to _IDLE_MS where the
        button's closings are timed by its interrupt (hal button_edge) and no bytes came: until
        the button's next due poll (Button.due_ms) or the LED's next change (Led.due_ms), so a
        press counts from its closing and the LED changes on time. machine.idle() also returns
        at the rp2 port's 1 ms wake-up alarm and at USB interrupts, so a loop of idle() calls
        woke the Python code some 3,300 times a second and ended passes early (155 passes a
        second, not 50, on the emulated Pico).

        Where idle() services DRDY itself (CircuitPython's poll of the pin, the simulator's
        link) it returns after every DRDY, so the loop counts DRDY periods instead of reading
        the clock: a wake-up costs one decrement and the HAL's idle(). A quit request
        (simulators) is seen by run() within _HOUSE_MS.
        """
        b = self.board
        if b.sleeps_with_irq:
            # the DRDY interrupt fills the ring while the core sleeps: one call, and the
            # wake-ups inside it (every interrupt, 1000 DRDY a second) stay in C
            b.sleep_ms(self._pass_ms(b))
            return
        if self.supervisor.fault:   # no conversions to count: by the clock
            t0 = b.ticks_ms()
            while not b.quit_requested():
                b.idle()
                if b.ticks_diff(b.ticks_ms(), t0) >= _HOUSE_MS:
                    return
            return
        n = self._house_idles
        idle = b.idle
        while n > 0:
            idle()
            n -= 1

    def _pass_ms(self, b):
        # (its own frame: in wait's, the calls' stack passed the 11 words of a frame on the C stack).
        # The raw stream (a capture: every sample a line) keeps 20 ms passes: on the unix stand-in, whose
        # DRDY is served only while the core waits, a 40 ms pass's output covered a block's window and
        # lost its sample (1 capture in 3 on a loaded host, tests/test_laptop_chain.py)
        if self.proto.heard or not b.button_edges or self.output.stream == "raw":
            return _HOUSE_MS
        return self.led.due_ms(self.button.due_ms(_IDLE_MS))


def start(hal):
    """Boot on real hardware: config.json -> hal.Board(cfg) -> App, unless the button is held.

    An exception that escapes the app anyway (its constructor, a HAL) is written to
    boot.txt before it reaches the REPL: the next boot comes up in safe mode."""
    body, _src, _problem = store.load("", "config")
    cfg, _problems = cfgmod.from_dict(body or {})
    board = hal.Board(cfg)
    if board.button():
        print("fluxcal: button held at boot, staying in the REPL")
        return None
    try:
        App(board).run()
    except Exception as e:
        bootguard.crashed(board.root, "%s: %s" % (e.__class__.__name__, e))
        raise
