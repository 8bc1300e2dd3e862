"""The firmware live on a pseudo-terminal, in real time, for tests that run `fluxcal` as a user does.

    with LiveHandheld(tmp_path, motion="hand") as hh:
        subprocess.run(["fluxcal", "status", "--port", hh.port])
        hh.kill()                  # the device dies: pacing stops, the pty closes

The firmware runs in this process (desktop.devicesim.runners, kind "cpython")
on a simulated handheld whose USB serial line is a real pty. The firmware
only moves when its simulated time is advanced; a thread here advances it in
small steps paced to the wall clock (sleeping while ahead), so a client in
another process meets a device that answers and streams in real time. The
firmware runs ~40x faster than real time here, so the pace holds on a busy
machine; `lag` records the worst delay seen.
"""

import threading
import time

from desktop.devicesim.runners import start_device
from desktop.devicesim.world import make_world

STEP_S = 0.01    # simulated time per step: a request waits at most about this long to be read


class LiveHandheld:
    def __init__(self, root, motion="stationary", seconds=60.0, rate=1000, seed=3, **scenario):
        self.world = make_world(serial="pty", motion=motion, seconds=seconds, rate=rate, seed=seed, **scenario)
        self.end = seconds - 0.5      # the scenario's inputs end there: the device stops, as if dead
        self.dev = start_device(self.world, str(root), kind="cpython")
        self.dev.run_until(0.3)       # boot
        self.port = self.world.serial_port
        self.lag = 0.0
        self.error = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._pace, name="pace", daemon=True)
        self._thread.start()

    def _pace(self):
        t_sim, t_wall = self.world.time, time.monotonic()
        try:
            while not self._stop.is_set() and self.world.time < self.end:
                due = t_sim + (time.monotonic() - t_wall)
                now = self.world.time
                if now < due:
                    self.lag = max(self.lag, due - now)
                    self.dev.run_until(min(due, now + 5 * STEP_S, self.end))
                else:
                    time.sleep(min(STEP_S, now - due + 0.001))
        except Exception as exc:  # noqa: BLE001 - the test reads it from .error
            self.error = exc

    def stop(self):
        """Stop time: the firmware neither answers nor streams any more (the pty stays open)."""
        self._stop.set()
        self._thread.join(timeout=10)

    def kill(self):
        """The device dies: time stops and the serial line goes away."""
        self.stop()
        self.dev.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.kill()
