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
firmware may pick) and is the same signal `simulate` digitises. A live
handheld (an operator deciding as time goes) or a `chunked` one (hours of
survey: the whole grid would not fit in memory) computes it chunk by chunk a
little ahead of the chips instead (:meth:`keep_ahead`, called by the World
before it lets time pass); the chips then hold only a window of it.
"""

import numpy as np

from desktop.sim.ads1292.bus import SPIBus
from desktop.sim.ads1292.chip import ADS1292
from desktop.sim.ads1292.registers import F_MOD
from desktop.sim.scenario import AnalogChain

LIVE_AHEAD_S = 0.25     # live: analog input computed this far ahead of the chips' time
_LIVE_BACK_S = 0.02     # and kept this far behind it (a conversion's sinc3 looks back 3 / rate)
CHUNK_AHEAD_S = 1.0     # chunked (scripted): longer chunks, fewer calls and reloads of the chips


class Handheld:
    """Two emulated chips and the scenario's analog signal.

    Parameters
    ----------
    scenario : desktop.sim.scenario.Scenario
    t0 : float
        Chip time (s) at which the scenario's motion begins (the firmware boots
        first; before t0 the sensor holds its first attitude).
    fault : (str or None, str or None)
        Fault injection for chip A and chip B (see ads1292/faults.py FAULTS);
        :meth:`set_fault` switches one at run time.
    chip_ids : (int, int)
        ID register values of chip A and chip B.
    batch : int
        Conversions each chip computes per vectorised call (ads1292/analog.py
        AnalogInput `batch`; also settable later as ``chip.batch``). The codes do not
        depend on it; 512 makes the byte-level path ~15x faster.
    operator : desktop.sim.operator.LiveOperator or None
        A live operator instead of the scenario's scripted motion (implies chunked).
    chunked : bool
        Compute the analog input as time goes (:meth:`keep_ahead`) rather than
        up front: memory stays bounded whatever the scenario's length. Whoever
        advances the chips must call keep_ahead first (the World does).
    """

    def __init__(self, scenario, t0=0.1, fault=(None, None), chip_ids=(0x53, 0x53), batch=1, operator=None,
                 chunked=False):
        sc = scenario
        motion_rng, noise_rng, rng_a, rng_b = sc.rngs()
        self.motion = sc.operator(motion_rng) if operator is None else operator
        self.live = operator is not None
        self.chunked = self.live or bool(chunked)
        self.ahead_s = LIVE_AHEAD_S if self.live else CHUNK_AHEAD_S
        self.ahead_until = float("inf")     # chip time up to which keep_ahead has nothing to do
        # the scenario's grid when given (8 kHz and up hold every data rate's conversion in whole
        # samples), else 16 kHz or more
        rate = max(16000, sc.grid_hz()) if sc.grid_rate == "auto" else sc.grid_hz()
        step = F_MOD // rate
        # noise scaled for a conversion 4 ticks into a grid sample (the byte path's
        # START lands anywhere; the sinc3's weights hardly depend on the phase)
        self._chain = AnalogChain(sc, self.motion, noise_rng, step, 4 % step)
        self.grid_rate, self._step, self.t0, self.scenario = rate, step, t0, sc
        self.sensor = self._chain.sensor
        k_a, k_b = sc.vref_tempco()      # each chip's reference drift (Scenario vref_drift)
        self.chips = [ADS1292(chip_ids[0], seed=rng_a, fault=fault[0], noise=sc.adc_noise, batch=batch,
                              vref_tempco=k_a),
                      ADS1292(chip_ids[1], seed=rng_b, fault=fault[1], noise=sc.adc_noise, batch=batch,
                              vref_tempco=k_b)]
        self.bus = SPIBus(self.chips)
        self._g0 = 0            # first grid sample the chips hold
        self._g_done = 0        # grid samples computed
        if self.chunked:
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
        """Live or chunked: make sure the chips hold the analog input up to chip time
        t + `ahead_s` (LIVE_AHEAD_S live, CHUNK_AHEAD_S chunked), computing the next chunk
        (from what the operator does now) when it runs short. Nothing to do while
        t <= `ahead_until`."""
        if not self.chunked:
            return
        rate, ahead = self.grid_rate, self.ahead_s
        need = int((t - self.t0 + ahead) * rate) + 1
        if need <= self._g_done - int(0.5 * ahead * rate):
            return              # enough ahead still
        end = need + int(ahead * rate)
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
        # the largest t for which `need` above stays within the margin (a little below it)
        self.ahead_until = self.t0 - ahead + (end - int(0.5 * ahead * rate) - 2) / rate

    def set_fault(self, chip, fault, rate=None):
        """Inject `fault` (ads1292/faults.py FAULTS; None clears it) into chip `chip` (0: A,
        1: B) from the current simulated time on; `rate` as ADS1292.set_fault (per frame,
        per bit, or the clock's relative error for "clock-drift")."""
        c = self.chips[chip]
        c.advance_to_tick(max(x.tick for x in self.chips))   # a chip the bus has not moved yet catches up
        c.set_fault(fault, rate)

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
