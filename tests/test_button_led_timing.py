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

app = import_device("app")
button = import_device("button")
hal = import_device("hal")
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

    button_edges = False    # polled alone (hal.Board's default): a press counts from the pass that finds it

    def button_edge(self, now):
        return now

    def led(self, on):
        self.writes.append((self.t - T0, on))


class TimedBoard(Board):
    """A board whose interrupt times the button's closings (hal_micropython.py): each ms of the
    pass's sleep the contact is looked at, and a closing's ms recorded, taken by button_edge as
    hal_micropython takes it (hal.EDGE_MS at most before the poll)."""
    sleeps_with_irq = True
    button_edges = True

    def __init__(self, contact):
        super().__init__()
        self.contact = contact
        self.closed = [0, 0]       # ticks_ms of the last closing, 1 until taken
        self.sleeps = []           # each pass's sleep, ms

    def button_edge(self, now):
        c = self.closed
        if c[1] and self.ticks_diff(now, c[0]) <= hal.EDGE_MS:
            c[1] = 0
            return c[0]
        return now

    def sleep_ms(self, ms):
        self.sleeps.append(ms)
        for _ in range(ms):
            self.t += 1
            was, self.pressed = self.pressed, self.contact(self.t - T0)
            if self.pressed and not was:
                self.closed[0] = self.t % PERIOD
                self.closed[1] = 1


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


def run_passes(contact, until, pattern=led.COLLECTING, heard=False, stream="off"):
    """The MicroPython main loop's passes (device/app.py App.wait: a short one where bytes came,
    else until the button's or the LED's next due time, at most _IDLE_MS), the board's interrupt
    timing the closings: [(ms, event)], the Button, the board."""
    b = TimedBoard(contact)
    btn = button.Button(b)
    lamp = led.Led(b)
    lamp.set(pattern)
    loop = type("Loop", (), {})()       # what App.wait reads
    loop.board, loop.button, loop.led = b, btn, lamp
    loop.proto = type("Proto", (), {"heard": heard})()
    loop.supervisor = type("Sup", (), {"fault": None})()
    loop.output = type("Out", (), {"stream": stream})()
    loop._pass_ms = lambda board: app.App._pass_ms(loop, board)
    events = []
    while b.t < T0 + until:
        ev = btn.poll()
        if ev is not None:
            events.append((b.t - T0, ev))
        lamp.update()
        app.App.wait(loop)
    return events, btn, b


@pytest.mark.parametrize("start", range(0, 40, 3))
@pytest.mark.parametrize("held", [41, 45, 70, 200])
def test_a_press_counts_from_its_closing_where_an_interrupt_times_it(start, held):
    # the contact closes at any phase of a 40 ms idle pass and holds `held` ms (polled every 20 ms,
    # a press had to hold 40-60 ms): one SHORT, and the press's time is the closing's to the ms
    # (a survey mark's), not the pass that found it
    close = 1000 + start
    events, btn, b = run_passes(lambda ms: close <= ms < close + held, 2000)
    assert [ev for _, ev in events] == [button.SHORT]
    assert btn.pressed_at == (T0 + close) % PERIOD
    assert events[0][0] <= close + held + button.Button.debounce_ms + 2 * app._HOUSE_MS


def test_idle_passes_are_long_and_a_closed_button_or_bytes_make_them_short():
    _, _, b = run_passes(lambda ms: False, 3000, pattern=led.SURVEY)
    assert max(b.sleeps) == app._IDLE_MS and b.sleeps.count(app._IDLE_MS) > 0.9 * len(b.sleeps)
    _, _, b = run_passes(lambda ms: ms >= 500, 3000, pattern=led.SURVEY)
    assert set(b.sleeps[-50:]) == {app._HOUSE_MS}               # held: the short pass
    _, _, b = run_passes(lambda ms: False, 3000, pattern=led.SURVEY, heard=True)
    assert set(b.sleeps) == {app._HOUSE_MS}                     # bytes at every poll
    _, _, b = run_passes(lambda ms: False, 3000, pattern=led.SURVEY, stream="raw")
    assert set(b.sleeps) == {app._HOUSE_MS}                     # a capture's every sample a line
    _, _, b = run_passes(lambda ms: False, 3000, pattern=led.SURVEY, stream="corrected")
    assert max(b.sleeps) == app._IDLE_MS                        # the survey's blocks: long passes


def pattern_writes(pattern, until):
    """[(ms, on)]: the pattern's writes, each phase's start (a zero-length phase writes nothing), before until."""
    want, t, on, k = [], 0, True, 0
    while t < until:
        if pattern[k % len(pattern)]:
            want.append((t, on))
        t += pattern[k % len(pattern)]
        on = not on
        k += 1
    return want


@pytest.mark.parametrize("pattern", [led.ENOUGH, led.FAULT, led.COLLECTING, led.FAILED])
def test_the_led_changes_on_time_between_long_passes(pattern):
    # the pass sleeps until the LED's next change: each change written within a ms of its time
    _, _, b = run_passes(lambda ms: False, 4000, pattern=pattern)
    want = pattern_writes(pattern, 3900)
    got = changes(b.writes)
    assert [on for _, on in got[:len(want)]] == [on for _, on in changes(want)]
    assert max(abs(g - w) for (g, _), (w, _) in zip(got, changes(want))) <= 1


def test_a_stale_closing_is_not_a_press_s_time():
    # a closing recorded longer than hal.EDGE_MS before the poll that finds the contact closed (a
    # release's bounce, say) is not taken: the press counts from that poll
    b = TimedBoard(lambda ms: False)
    btn = button.Button(b)
    b.closed = [(T0 + 100) % PERIOD, 1]
    b.t, b.pressed = T0 + 101 + hal.EDGE_MS, True
    assert btn.poll() is None
    assert btn._changed == (T0 + 101 + hal.EDGE_MS) % PERIOD
    b.closed = [(T0 + 2000) % PERIOD, 1]       # and within it, it is
    b.t, b.pressed = T0 + 2000 + hal.EDGE_MS, False
    btn.poll()
    b.pressed = True
    btn.poll()
    assert btn._changed == (T0 + 2000) % PERIOD


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
    want = pattern_writes(pattern, 8000)
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
