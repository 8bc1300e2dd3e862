# MicroPython script for the emulated Pico (desktop/bench/pico_loop.py copies it to /disk with the
# firmware as .mpy and imports it): what one main-loop pass of device/app.py costs, piece by piece,
# with no samples flowing. The App is built on the real rp2 HAL (hal_micropython.Board) as at boot;
# no chips are on the pins, so its probe fails (adc_probe) and the script then puts the supervisor
# in the state of a healthy boot (Health judging, FRAMES moved by the script each pass, as 20 ms
# of conversions would): the pass then takes the path it takes on a board after boot, the ring
# empty. The cycles are counted by the runner on its profiling port (desktop/devicesim/pico/
# parts.mjs): the script names the piece about to run (PORT = n | ENTRY, a call counted) and the
# runner charges thread-mode cycles to it, interrupts apart. Phases (the part numbers, which the
# bench names): after boot without a session, then with a calibration session started (its quiet
# ticks), each first piece by piece (BASE + the piece), then App.run() itself for RUN_MS (its
# thread-mode cycles, the wake-ups in its sleeps included; a Timer moves FRAMES every 200 ms);
# the collector off in both. Prints one JSON line: the run's emulated us and the bytes allocated
# a pass by each piece (gc off, gc.mem_alloc).
import gc
import json
import sys
import time

sys.path.insert(0, "/disk")
import app as appmod  # noqa: E402
import config as cfgmod  # noqa: E402
import hal_micropython  # noqa: E402
from acquisition import FRAMES  # noqa: E402
from health import Health  # noqa: E402
from machine import mem32  # noqa: E402
from micropython import const  # noqa: E402

_PORT = const(0x40068000)
_ENTRY = const(0x100)
PASSES = 250         # 5 emulated s a phase, piece by piece
RUN_MS = 5000        # then App.run() itself
# a piece's number within a phase (the bench's PIECES), added to the phase's base
POLL, CHECK, BUTTON, PROTO, TICK, LED, PASSED, FEED, WAIT, WRITE, STEP = 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11
WHOLE = 20


def flowing(acq):
    acq.state[FRAMES] += 20   # a pass's conversions at 1000 SPS: Health sees them flow


def takes_now(a):
    """Whether this tree's Led.update and CalibrationFlow.tick take the pass's ticks (app.py reads
    them once for both) or read the clock themselves (before 2026-12-03)."""
    try:
        a.led.update(a.board.ticks_ms())
        return True
    except TypeError:
        return False


def pieces(a, base, n, now_arg):
    """n passes, step()'s pieces in its order, each named on the port before it runs."""
    b = a.board
    sup = a.supervisor
    flow = a.flow
    acq = a.acq
    feed = b.watchdog_feed
    for _ in range(n):
        flowing(acq)
        mem32[_PORT] = (base + POLL) | _ENTRY
        acq.poll(a._sample_cb, a._drain, a._gap_cb)
        mem32[_PORT] = (base + CHECK) | _ENTRY
        sup.check(b.ticks_ms())
        mem32[_PORT] = (base + BUTTON) | _ENTRY
        a.button.poll()
        mem32[_PORT] = (base + PROTO) | _ENTRY
        a.proto.poll()
        mem32[_PORT] = (base + TICK) | _ENTRY
        if now_arg:
            now = b.ticks_ms()      # step's second clock read, charged here
            if flow.session is not None:
                flow.tick(now)
            mem32[_PORT] = (base + LED) | _ENTRY
            a.led.update(now)
        else:
            if flow.session is not None:
                flow.tick()
            mem32[_PORT] = (base + LED) | _ENTRY
            a.led.update()
        mem32[_PORT] = (base + PASSED) | _ENTRY
        a.guard.passed()
        mem32[_PORT] = (base + FEED) | _ENTRY
        feed()
        mem32[_PORT] = (base + WAIT) | _ENTRY
        a.wait()
        mem32[_PORT] = (base + WRITE) | _ENTRY    # the next write: what one costs
        mem32[_PORT] = base


def whole(a, base, ms):
    """App.run() itself for `ms` (a one-shot Timer sets quit): (passes, emulated us). The passes are
    counted from the time: a pass is _HOUSE_MS asleep and its awake cycles (the bench's figure)."""
    from machine import Timer
    a.quit = False
    acq = a.acq
    # conversions seen between Health's checks (every 250 ms), as the pieces' passes move them
    bump = Timer(period=200, callback=lambda t: flowing(acq))
    Timer(mode=Timer.ONE_SHOT, period=ms, callback=lambda t: setattr(a, "quit", True))
    t0 = time.ticks_us()
    mem32[_PORT] = (base + WHOLE) | _ENTRY
    a.run()
    mem32[_PORT] = base
    bump.deinit()
    return time.ticks_diff(time.ticks_us(), t0)


def allocated(a, n, now_arg):
    """Bytes allocated a pass by each piece (gc off): garbage that a collection pays for later."""
    b = a.board
    sup = a.supervisor
    flow = a.flow
    got = {}
    calls = (("check", lambda: sup.check(b.ticks_ms())), ("button", a.button.poll), ("proto", a.proto.poll),
             ("tick", lambda: flow.session is not None and (flow.tick(b.ticks_ms()) if now_arg else flow.tick())),
             ("led", (lambda: a.led.update(b.ticks_ms())) if now_arg else a.led.update),
             ("passed", a.guard.passed), ("feed", b.watchdog_feed), ("step", a.step))
    gc.collect()
    gc.disable()
    feed = b.watchdog_feed
    for name, f in calls:
        m = gc.mem_alloc
        total = 0
        for _ in range(n):
            flowing(a.acq)
            m0 = m()
            f()
            total += m() - m0
            feed()      # without it the watchdog reset the emulated chip in this loop
        got[name] = total / n
    gc.enable()
    return got


def main():
    cfg = cfgmod.defaults()
    board = hal_micropython.Board(cfg, root="/disk")
    a = appmod.App(board)
    sup = a.supervisor
    probe = sup.fault_code          # no chips on the pins: adc_probe
    sup.fault = sup.fault_code = None
    sup.verifying = False
    if sup.health is None:
        sup.health = Health(a.acq, cfg["rate"], board.ticks_ms())
    a._setup_pipeline()             # as after a healthy boot (the LED's steady pattern too)
    a.watchdog_ms = cfg["watchdog_ms"] if board.watchdog_start(cfg["watchdog_ms"]) else None
    now_arg = takes_now(a)
    out = {"probe": probe, "watchdog": a.watchdog_ms, "passes": PASSES}
    gc.collect()
    out["free"] = gc.mem_free()
    out["house_ms"] = appmod._HOUSE_MS
    gc.disable()    # the cycles without collections: what a pass allocates is counted apart
    pieces(a, 100, PASSES, now_arg)
    out["run_us"] = whole(a, 100, RUN_MS)
    gc.enable()
    out["alloc"] = allocated(a, 50, now_arg)
    a.flow.start()
    out["session"] = a.flow.session is not None
    gc.collect()
    gc.disable()
    pieces(a, 200, PASSES, now_arg)
    out["run_us_session"] = whole(a, 200, RUN_MS)
    gc.enable()
    out["alloc_session"] = allocated(a, 50, now_arg)
    out["fault"] = sup.fault_code   # None: the supervisor stayed healthy throughout
    mem32[_PORT] = 0
    board.hand_back()
    print(json.dumps(out))


main()
