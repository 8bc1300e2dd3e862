"""One hand calibration and one survey spin on a virtual handheld, with what the bench reads meanwhile
(desktop/bench/pico.py runs it on the emulated Pico, plain and profiled, and on the `micropython`
runtime for the spin's comparison).

    s = Session(dev, clock, act, figures=board.figures)   # dev: desktop.link's Device on the port
    got = s.run(window_s=10.0)

The steps, each timed on the board's own clock (`clock()`: emulated or simulated seconds):
the operator follows the LED after `start-cal` for `window_s` (the calibrating window: auto_finish
is off, so the session collects the whole time), `finish-cal`, then `stream corrected` and a
steady spin of one turn a second for `window_s` (the survey window; PTP of the streamed |B| over
it). `status` is asked every SAMPLE_S of board time in both windows (on the board's clock, so
what the requests cost the firmware does not depend on the host's speed): its mem_free is
sampled (garbage not yet collected counts as used).
"""

import time

SETTLE_S = 1.0        # board seconds after an operator's change before a window opens
SAMPLE_S = 2.5        # board seconds between status samples (each costs the firmware 3-7 M cycles: benchmarks.md)
DRAIN_S = 5.0         # wall seconds at most spent reading the blocks from before the survey window


class Session:
    def __init__(self, dev, clock, act, figures=None, sample_s=SAMPLE_S):
        self.dev = dev
        self.sample_s = sample_s      # board s between status samples (past the window: none in it)
        self.clock = clock            # () -> the board's seconds
        self.act = act                # act(action): the operator (virtual_handheld.ACTIONS)
        self.figures = figures        # (start=False) -> the runner's figures (pico.Runner), or None

    def wait(self, seconds):
        """Until `seconds` of board time have passed; the status samples taken meanwhile."""
        now = self.clock()
        end = now + seconds
        samples = []
        nxt = now + self.sample_s
        while now < end:
            if now >= nxt:
                samples.append(self.dev.ask("status", timeout=120))
                nxt += self.sample_s
            time.sleep(0.2)
            now = self.clock()
        return samples

    def window(self, seconds):
        """{"before", "after": runner figures, "samples": statuses, "status": the last one}."""
        before = self.figures(start=True) if self.figures else None
        samples = self.wait(seconds)
        after = self.figures() if self.figures else None
        status = self.dev.ask("status", timeout=120)
        return {"before": before, "after": after, "samples": samples + [status], "status": status}

    def run(self, window_s):
        dev = self.dev
        dev.ask("start-cal", timeout=120)
        self.act("follow")
        self.wait(SETTLE_S)
        cal = self.window(window_s)
        result = dev.ask("finish-cal", timeout=300)["result"]
        dev.ask("stream corrected", timeout=120)
        self.act("spin")
        self.wait(SETTLE_S)
        # the blocks before the window, those still in the relay's pipe too: read until none came
        # for 0.3 s, or for DRAIN_S wall seconds (a board as fast as real time never pauses)
        end = time.monotonic() + DRAIN_S
        while time.monotonic() < end and dev.next_event(0.3) is not None:
            pass
        survey = self.window(window_s)
        blocks = []
        while True:
            ev = dev.next_event(0.0)
            if ev is None:
                break
            if ev.get("ev") == "data":
                blocks.append(ev)
        dev.ask("stream off", timeout=120)
        self.act("follow")
        return {"calibrating": cal, "survey": survey, "result": result, "spin": [b["f"] for b in blocks]}


def configure(dev, settings):
    """config set each key (persisted on the board's flash)."""
    for key, value in settings.items():
        dev.ask("config set %s %s" % (key, str(value).lower() if isinstance(value, bool) else repr(value)),
                timeout=120)
