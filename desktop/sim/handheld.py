"""The simulated handheld for the firmware: two ADS1292 on one SPI bus, fed by a scenario.

    from desktop.sim.handheld import Handheld
    hw = Handheld(Scenario(seconds=150, motion="hand"))
    hw.bus.select(0); hw.bus.transfer(b"\\x11"); hw.bus.select(None)   # chip A: SDATAC
    hw.bus.start = True                 # shared START line
    hw.bus.wait_drdy(0)                 # DRDY of chip A is wired to the MCU; all clocks move
    hw.advance(0.001)                   # time passes for both chips

Chip A (bus index 0) gets the X and Y front-end outputs, chip B (index 1) Z and
nothing on CH2 (the firmware sets CH2 to MUX=0100, the die temperature). The
analog signal is computed for the whole scenario up front on the scenario's
grid (16 kHz or more for a byte-level run: sinc3 exact at every data rate the
firmware may pick) and is the same signal `simulate` digitises.
"""

import numpy as np

from desktop.sim.ads1292.bus import SPIBus
from desktop.sim.ads1292.chip import ADS1292
from desktop.sim.ads1292.registers import F_MOD
from desktop.sim.scenario import AnalogChain

LIVE_AHEAD_S = 0.25     # live: analog input computed this far ahead of the chips' time
_LIVE_BACK_S = 0.02     # and kept this far behind it (a conversion's sinc3 looks back 3 / rate)


class Handheld:
    """Two emulated chips and the scenario's analog signal.

    Parameters
    ----------
    scenario : desktop.sim.scenario.Scenario
    t0 : float
        Chip time (s) at which the scenario's motion begins (the firmware boots
        first; before t0 the sensor holds its first attitude).
    fault : (str or None, str or None)
        Fault injection for chip A and chip B (see ads1292/chip.py FAULTS).
    chip_ids : (int, int)
        ID register values of chip A and chip B.
    batch : int
        Conversions each chip computes per vectorised call (ads1292/chip.py
        ADS1292 `batch`; also settable later as ``chip.batch``). The codes do not
        depend on it; 512 makes the byte-level path ~15x faster.
    """

    def __init__(self, scenario, t0=0.1, fault=(None, None), chip_ids=(0x53, 0x53), batch=1, operator=None):
        sc = scenario
        motion_rng, noise_rng, rng_a, rng_b = sc.rngs()
        self.motion = sc.operator(motion_rng) if operator is None else operator
        self.live = operator is not None
        rate = max(16000, sc.grid_hz())
        step = F_MOD // rate
        # noise scaled for a conversion 4 ticks into a grid sample (the byte path's
        # START lands anywhere; the sinc3's weights hardly depend on the phase)
        self._chain = AnalogChain(sc, self.motion, noise_rng, step, 4 % step)
        self.grid_rate, self._step, self.t0, self.scenario = rate, step, t0, sc
        self.sensor = self._chain.sensor
        self.chips = [ADS1292(chip_ids[0], seed=rng_a, fault=fault[0], noise=sc.adc_noise, batch=batch),
                      ADS1292(chip_ids[1], seed=rng_b, fault=fault[1], noise=sc.adc_noise, batch=batch)]
        self.bus = SPIBus(self.chips)
        self._g0 = 0            # first grid sample the chips hold
        self._g_done = 0        # grid samples computed
        if self.live:
            self.grid = None
            self.keep_ahead(0.0)
        else:
            self.grid = self._chain.grid(0, int(sc.seconds * rate) + 1, step)
            self._g_done = len(self.grid["t"])
            self._load(self.grid)

    def _load(self, grid):
        v = grid["volts"]
        t0 = self.t0 + self._g0 / self.grid_rate
        self.chips[0].load(v[:, :2], self.grid_rate, t0, temperature_c=grid["temp"])
        self.chips[1].load(np.c_[v[:, 2], np.zeros(len(v))], self.grid_rate, t0, temperature_c=grid["temp"])

    def step_field(self, nT):
        """Live: the field grows by `nT` along its direction from the first time not yet
        computed on (the past does not change); returns that chip time."""
        t = self.t0 + self._g_done / self.grid_rate
        self._chain.field.add_step(t - self.t0, nT)
        return t

    def keep_ahead(self, t):
        """Live: make sure the chips hold the analog input up to chip time t + LIVE_AHEAD_S
        (computing the next chunk, from what the operator does now, when it runs short)."""
        if not self.live:
            return
        rate = self.grid_rate
        need = int((t - self.t0 + LIVE_AHEAD_S) * rate) + 1
        if need <= self._g_done - int(0.5 * LIVE_AHEAD_S * rate):
            return              # enough ahead still
        end = need + int(LIVE_AHEAD_S * rate)
        new = self._chain.grid(self._g_done, end, self._step)
        keep_from = max(0, int((t - self.t0 - _LIVE_BACK_S) * rate))
        if self.grid is None:
            grid = new
            self._g0 = 0
        else:
            cut = max(0, keep_from - self._g0)
            grid = {k: np.concatenate([v[cut:], new[k]]) for k, v in self.grid.items()}
            self._g0 += cut
        self.grid, self._g_done = grid, end
        self._load(grid)

    def advance(self, seconds):
        """Let time pass for both chips."""
        self.bus.advance(seconds)

    @property
    def time(self):
        return self.chips[0].time

    def truth(self, t):
        """True |B| (nT) and sensor-frame field (N, 3) nT at chip times t (N,) (live: within
        the window the chips hold)."""
        g = np.clip(np.rint((np.asarray(t) - self.t0) * self.grid_rate).astype(int) - self._g0, 0,
                    len(self.grid["t"]) - 1)
        return self.grid["bmag"][g], self.grid["b"][g]
