"""Simulated time paced to the wall clock, for a device a person (or a program) uses live.

    pacer = Pacer(link.serve, lambda: world.time)    # or an in-process device's run_until
    pacer.run(stop)                                  # in a thread; pacer.capacity, pacer.lag

The device runs in slices of STEP_S of simulated time; after each, the pacer
sleeps until the wall clock has caught up. `capacity` is simulated seconds
served per wall second spent serving (above 1: the firmware keeps up with real
time, with that much to spare); `lag` is how far simulated time trails the
wall clock (0 while it keeps up). A firmware that falls more than BEHIND_S
behind is reported through `on_behind` (fluxcal emulate stops, loudly).
"""

import time

STEP_S = 0.01       # simulated time per slice
BEHIND_S = 1.0      # trailing the wall clock by more than this is falling behind
_WINDOW_S = 5.0     # capacity is measured over this much wall time


class Pacer:
    def __init__(self, run_until, sim_time, speed=1.0, on_step=None, on_behind=None):
        self.run_until = run_until      # run_until(t): run the device until simulated time t
        self.sim_time = sim_time
        self.speed = speed
        self.on_step = on_step          # on_step(): after each slice (the operator looks at the LED)
        self.on_behind = on_behind      # on_behind(lag_s, capacity): fell behind real time
        self.capacity = None
        self.lag = 0.0
        self._busy = 0.0                # wall seconds spent serving in the current window
        self._served = 0.0              # simulated seconds served in the current window
        self._window_start = None

    def run(self, stop):
        """Serve until stop (a threading.Event) is set or the device ends (its exception rises)."""
        wall0 = time.monotonic()
        sim0 = self.sim_time()
        self._window_start = wall0
        while not stop.is_set():
            due = sim0 + (time.monotonic() - wall0) * self.speed     # where real time is
            t_before = self.sim_time()
            w_before = time.monotonic()
            self.run_until(max(due, t_before) + STEP_S)
            w_after = time.monotonic()
            self._account(self.sim_time() - t_before, w_after - w_before, w_after)
            if self.on_step is not None:
                self.on_step()
            ahead = self.sim_time() - (sim0 + (time.monotonic() - wall0) * self.speed)
            self.lag = max(0.0, -ahead)
            if ahead > 0:
                stop.wait(ahead / self.speed)
            elif self.lag > BEHIND_S and self.on_behind is not None:
                self.on_behind(self.lag, self.capacity)
                return

    def _account(self, sim_dt, wall_dt, now):
        self._served += sim_dt
        self._busy += wall_dt
        if now - self._window_start >= _WINDOW_S:
            if self._busy > 0:
                self.capacity = self._served / self._busy
            self._served = self._busy = 0.0
            self._window_start = now
