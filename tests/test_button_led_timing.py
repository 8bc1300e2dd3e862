"""The button's debounce and long press, the LED's patterns and the ADC supervisor's checks, in time.

The main loop polls them once a pass (device/app.py, every _HOUSE_MS = 20 ms) and each returns at
once when nothing is due, in a frame small enough for the C stack (device/app.py, Frames: the rest
is in a second method): these tests drive them from a clock they set, pass by pass, and hold the
times at which things happen to what the constants say, so a shortcut that skips a due check, or
reads the clock too late, fails here. The clock
wraps as MicroPython's ticks_ms does (2**30 ms on the rp2 port) and is started just before the
wrap, so a plain difference where ticks_diff belongs fails too.
"""

from array import array

import pytest

from desktop.firmware.files import import_device

button = import_device("button")
led = import_device("led")
health = import_device("health")
acquisition = import_device("acquisition")

PERIOD = 1 << 30          # ticks_ms wraps here (MicroPython's TICKS_PERIOD on 32-bit ports)
PASS_MS = 20              # device/app.py _HOUSE_MS
T0 = PERIOD - 1000        # the clock wraps one second in


class Board:
    """ticks as MicroPython's time has them; the button's contact and the LED's writes."""

    def __init__(self):
        self.t = T0
        self.pressed = False
        self.writes = []      # (ms since T0, on) for each led() call
        self.reads = 0        # clock reads

    def ticks_ms(self):
        self.reads += 1
        return self.t % PERIOD

    def ticks_diff(self, a, b):
        return ((a - b + PERIOD // 2) % PERIOD) - PERIOD // 2

    def button(self):
        return self.pressed

    def led(self, on):
        self.writes.append((self.t - T0, on))


def run_button(contact, until, step=PASS_MS):
    """Poll a Button every `step` ms from T0 to T0 + until; contact(ms) says whether it is closed.
    [(ms, event)] of the events it gave, and the Button."""
    b = Board()
    btn = button.Button(b)
    events = []
    for ms in range(0, until, step):
        b.t = T0 + ms
        b.pressed = contact(ms)
        ev = btn.poll()
        if ev is not None:
            events.append((ms, ev))
    return events, btn, b


def test_a_short_press_is_reported_once_on_release_after_the_debounce():
    events, btn, _ = run_button(lambda ms: 100 <= ms < 300, 2000)
    # closed at 100: seen, then the level holds at 140 (30 ms later, the next pass); opened at
    # 300: seen, released at 340
    assert events == [(340, button.SHORT)]
    assert btn.pressed_at == (T0 + 100) % PERIOD      # the first edge, across the wrap


def test_bounces_shorter_than_the_debounce_give_nothing():
    # contact chatter: closed on one pass in three, never 30 ms in a row
    events, _, _ = run_button(lambda ms: 100 <= ms < 600 and ms % 60 == 0, 2000)
    assert events == []


def test_a_long_press_fires_once_while_held_and_its_release_gives_no_short():
    events, _, b = run_button(lambda ms: 100 <= ms < 4000, 5000)
    # held from 140 (debounced): LONG at the first pass 1500 ms after, nothing on release
    assert events == [(1640, button.LONG)]
    assert button.Button.long_ms == 1500 and button.Button.debounce_ms == 30


def run_led(pattern, until, step=PASS_MS, flash=None):
    b = Board()
    d = led.Led(b)
    d.set(pattern)
    if flash is not None:
        d.flash(flash)
    for ms in range(0, until, step):
        b.t = T0 + ms
        d.update()
    return b.writes


def changes(writes):
    """The writes that changed the LED: [(ms, on)]."""
    out = []
    for ms, on in writes:
        if not out or out[-1][1] != on:
            out.append((ms, on))
    return out


@pytest.mark.parametrize("pattern", [led.UNCALIBRATED, led.SURVEY, led.COLLECTING, led.SLOW_DOWN, led.SAFE])
def test_a_steady_pattern_changes_the_led_at_its_times_and_writes_only_then(pattern):
    writes = run_led(pattern, 8000, step=10)
    want, t, on, k = [], 0, True, 0
    while t < 8000:
        if pattern[k % len(pattern)]:
            want.append((t, on))
        t += pattern[k % len(pattern)]
        on = not on
        k += 1
    assert changes(writes) == changes(want)
    assert len(writes) == len(changes(writes))     # no write between changes


def test_a_one_shot_runs_once_then_the_steady_pattern_starts_over():
    writes = changes(run_led(led.SURVEY, 6000, step=10, flash=led.DONE_QUICK))
    # three 600 ms pulses after 300 ms off, then 400 ms off (2.9 s); SURVEY from 2900: on 1 s, off 1 s
    assert writes == [(0, False), (300, True), (900, False), (1100, True), (1700, False), (1900, True),
                      (2500, False), (2900, True), (3900, False), (4900, True), (5900, False)]


def test_the_supervisor_s_health_names_a_stopped_adc_at_its_deadline():
    class Acq:
        window = 2
        state = array("i", bytes(4 * 16))   # the acquisition's counters (FRAMES, BLOCKS, ...)

    acq = Acq()
    b = Board()
    h = health.Health(acq, 1000, b.ticks_ms())
    found = None
    for ms in range(0, 3000, PASS_MS):
        b.t = T0 + ms
        if ms < 1000:
            acq.state[acquisition.FRAMES] += 20     # conversions flow for the first second
        p = h.check(b.ticks_ms(), b.ticks_diff)
        if p is not None:
            found = (ms, p[0])
            break
    # checked at the first pass CHECK_MS (250) or more after the last check: 260, 520, 780, 1040
    # (which saw the frames of the passes up to 980 move), then 1300, 260 ms past the 1040 check
    # (deadline 100 ms): named there, not a check later
    assert found == (1300, "adc_no_drdy")
