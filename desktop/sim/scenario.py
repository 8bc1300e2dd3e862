"""The whole handheld, vectorised: operator -> field -> fluxgate -> two ADS1292.

    from desktop.sim.scenario import Scenario, simulate
    cap = simulate(Scenario(seconds=120))          # dict of arrays (desktop/formats/capture.py keys)

Chip A digitises X (CH1) and Y (CH2); chip B digitises Z (CH1) and its own
temperature sensor (CH2, MUX=0100). Both run continuously from START at
tick 0 with the same configuration, so their DRDYs coincide.

The analog signal is computed on a grid of `grid_rate` (16 kHz default: fMOD/8,
a whole number of samples per conversion at every data rate) in chunks of a
few seconds, each carrying the filter states and the last grid samples the
sinc3 window needs into the next, then :func:`desktop.sim.ads1292.convert`
turns it into codes exactly as the byte-level emulator does.

Random streams (numpy Generators, one per purpose, all derived from the seeds):
`seed` alone fixes the sensor's errors; `motion_seed` the operator's motion;
the noise realisations (sensor and ADC) derive from both, so two captures of
the same sensor with different motions have independent noise.
"""

import json

import numpy as np

from desktop.sim.ads1292 import registers as ads
from desktop.sim.ads1292.convert import NO_NOISE, convert, sinc3_kernel
from desktop.sim.field import DECLINATION_DEG, EARTH_NT, INCLINATION_DEG, Field, earth_vector
from desktop.sim.filters import lowpass
from desktop.sim.motion import make_motion, to_sensor
from desktop.sim.sensor import Fluxgate

RATES = ads.DATA_RATES
VREF_PPM_PER_C = 45.0      # the internal reference's drift bound [DS §6.5]
VREF_STREAM = 1292         # the seed's stream for the reference drifts (apart from the sensor's)


class Scenario:
    """All knobs of one simulated capture (defaults: the paper's in-situ setup).

    Parameters (keyword only)
    -------------------------
    sensor : "mag649" | "mag648"
    seed : int                 sensor errors
    motion : see desktop.sim.motion.MOTIONS
    motion_seed : int
    seconds : float            capture length, s
    rate : int                 ADS1292 data rate, SPS (125 .. 8000)
    rot_rate : float           typical rotation rate, rev/s
    coverage : float           fraction of the sphere the motion may reach
    noise : float              sensor white noise, nT rms per conversion
    pink : float               sensor 1/f noise, nT rms
    bandwidth : float or None  override the preset's bandwidth (None: the preset)
    poles : int                the sensor's response: 1 first order, 2 two equal poles
                               with the same -3 dB bandwidth
    bandwidth_spread : float   each axis' bandwidth drawn within +- this share of it (from seed)
    ideal : bool               a perfect sensor and front end
    adc_noise : bool           the ADS1292's input-referred noise [DS §7.1]
    gain : int                 PGA gain of the field channels
    vref_4v : bool             4.033 V reference instead of 2.42 V
    field_nT, inclination_deg, declination_deg : the local Earth field
    drift : float              field drift, nT/min
    gradient : float           field gradient, nT/m
    dipole : dict or None      passing dipole (see desktop.sim.field.Field)
    temp_c, temp_drift : float temperature at start (C) and its drift (C/min)
    temp_profile : list or None  [(t_s, temp_c), ...]: the temperature piecewise linear
                               through these points (held before the first and after
                               the last); replaces temp_c and temp_drift (which must
                               then be 0)
    vref_drift : "seed", float or (float, float)
                               the ADS1292 internal reference's drift, ppm/C about 25 C,
                               one per chip (A: X, Y; B: Z and the die temperature);
                               "seed": each drawn uniformly within +-45 ppm/C [DS §6.5]
                               from `seed` (its own stream: the sensor's errors are
                               unchanged); 0: none. No effect at 25 C.
    grid_rate : int or "auto"  analog grid, Hz (128 kHz / 1, 2, 4, 8 or 16); auto:
                               max(8 kHz, 2 x rate), two or more samples per
                               conversion and 4 kHz of analog bandwidth
    dwell : float              hold per attitude for uniform / cap motions, s
    """

    DEFAULTS = dict(sensor="mag649", seed=0, motion="hand", motion_seed=1, seconds=120.0,
                    rate=4000, rot_rate=1.0, coverage=1.0, noise=0.1, pink=0.0,
                    bandwidth="preset", poles=1, bandwidth_spread=0.0, ideal=False, adc_noise=True, gain=1, vref_4v=False,
                    field_nT=EARTH_NT, inclination_deg=INCLINATION_DEG, declination_deg=DECLINATION_DEG,
                    drift=0.0, gradient=0.0, dipole=None, temp_c=25.0, temp_drift=0.0,
                    temp_profile=None, vref_drift="seed", grid_rate="auto", dwell=0.002, survey=None)
    # motion "survey": the walk and the site (desktop/sim/walk.py, desktop/sim/site.py)
    SURVEY_DEFAULTS = dict(width_m=20.0, length_m=20.0, spacing_m=0.5, zigzag=True, speed=1.0,
                           site_seed=0, clutter_ptp=2.0, diurnal_nT=20.0, pipe=True)

    def __init__(self, **kw):
        unknown = set(kw) - set(self.DEFAULTS)
        if unknown:
            raise TypeError("unknown scenario settings: %s" % ", ".join(sorted(unknown)))
        self.__dict__.update(dict(self.DEFAULTS, **kw))
        if int(self.rate) not in RATES:
            raise ValueError("rate must be one of the ADS1292 data rates %s SPS, got %r"
                             % (", ".join(map(str, RATES)), self.rate))
        if self.gain not in ads.GAINS:
            raise ValueError("gain must be one of %s" % (sorted(ads.GAINS),))
        if not 0.0 < self.coverage <= 1.0:
            raise ValueError("coverage must be in (0, 1], got %r" % self.coverage)
        if self.seconds <= 0:
            raise ValueError("seconds must be positive")
        if self.temp_profile is not None:
            pts = [(float(t), float(c)) for t, c in self.temp_profile]
            times = [t for t, _ in pts]
            if not pts or any(b < a for a, b in zip(times, times[1:])):
                raise ValueError("temp_profile must be (t_s, temp_c) points in time order")
            if not all(-60.0 <= c <= 130.0 and np.isfinite(t) for t, c in pts):
                raise ValueError("temp_profile temperatures must be within -60..130 C at finite times")
            if self.temp_drift:
                raise ValueError("temp_profile replaces temp_drift: give one of them")
            self.temp_profile = [list(p) for p in pts]    # JSON-ready
        self.vref_tempco()                                  # checks vref_drift
        self._walk = self._site = None
        if self.motion == "survey":
            unknown = set(self.survey or {}) - set(self.SURVEY_DEFAULTS)
            if unknown:
                raise ValueError("unknown survey settings: %s" % ", ".join(sorted(unknown)))
            self.survey = dict(self.SURVEY_DEFAULTS, **(self.survey or {}))
            self.seconds = self.walk().seconds          # the walk decides how long the capture is

    def walk(self):
        """The survey's walk (desktop.sim.walk.SurveyWalk), from motion_seed; None for other motions."""
        if self.motion != "survey":
            return None
        if self._walk is None:
            from desktop.sim.walk import make_walk
            s = self.survey
            rng = np.random.default_rng(np.random.SeedSequence([int(self.motion_seed), 649]))
            self._walk = make_walk(rng, s["width_m"], s["length_m"], s["spacing_m"], s["zigzag"], s["speed"])
        return self._walk

    def site(self):
        """The surveyed site (desktop.sim.site.Site); None for other motions."""
        if self.motion != "survey":
            return None
        if self._site is None:
            from desktop.sim.site import make_site
            s = self.survey
            self._site = make_site(s["width_m"], s["length_m"], s["site_seed"], s["clutter_ptp"],
                                   s["diurnal_nT"], s["pipe"],
                                   earth_vector(1.0, self.inclination_deg, self.declination_deg))
        return self._site

    def temperature(self, t):
        """Temperature (C) at times t (s), an array like t (temp_profile, else temp_c + temp_drift t)."""
        t = np.asarray(t, dtype=float)
        if self.temp_profile is not None:
            pts = np.array(self.temp_profile)
            return np.interp(t, pts[:, 0], pts[:, 1])
        return self.temp_c + self.temp_drift * t / 60.0

    def vref_tempco(self):
        """(2,) reference drift of chip A and chip B, relative per C about 25 C (vref_drift)."""
        v = self.vref_drift
        if self.ideal:
            return np.zeros(2)
        if isinstance(v, str):
            if v != "seed":
                raise ValueError("vref_drift must be 'seed', a number or two numbers (ppm/C)")
            rng = np.random.default_rng(np.random.SeedSequence([int(self.seed), VREF_STREAM]))
            return rng.uniform(-VREF_PPM_PER_C, VREF_PPM_PER_C, 2) * 1e-6
        k = np.broadcast_to(np.asarray(v, dtype=float), (2,)) * 1e-6
        if not np.all(np.isfinite(k)):
            raise ValueError("vref_drift must be finite")
        return k.copy()

    def code_model(self, temp_c):
        """(P (3, 3), q (3,)): noise-free DC codes of X, Y, Z = P b + q for the field b (nT,
        sensor frame) at a steady temperature temp_c (C): the sensor's eq. (1), the front end
        and each chip's reference at that temperature. The exact calibration there (the
        floor) is matrix P^-1 (up to a rotation), offset q."""
        fg = self.fluxgate()
        dt = float(temp_c) - 25.0
        cfg = ads.Config(self.registers()[0])
        k_v = self.vref_tempco()[[0, 0, 1]]
        per_volt = cfg.gain[0] * ads.FULL_SCALE_CODE / (cfg.vref * (1.0 + k_v * dt))   # codes per V
        v_per_nT = fg.params["sensitivity_V_per_nT"] * fg.att
        p = (per_volt * v_per_nT * (1.0 + fg.tempco_scale * dt))[:, None] * fg.distortion
        q = per_volt * ((fg.offset + fg.tempco_offset * dt) * v_per_nT + fg.fe_offset)
        return p, q

    def grid_hz(self):
        """The analog grid rate in Hz."""
        if self.grid_rate == "auto":
            return max(8000, 2 * int(self.rate))
        return int(self.grid_rate)

    def to_dict(self):
        return {k: getattr(self, k) for k in self.DEFAULTS}

    def fluxgate(self):
        over = {"noise_nT": self.noise, "pink_nT": self.pink, "poles": self.poles,
                "bandwidth_spread": self.bandwidth_spread}
        if self.bandwidth != "preset":
            over["bandwidth_hz"] = self.bandwidth
        return Fluxgate(self.sensor, seed=self.seed, ideal=self.ideal, **over)

    def field(self):
        earth = earth_vector(self.field_nT, self.inclination_deg, self.declination_deg)
        if self.motion == "survey":
            from desktop.sim.site import SiteField
            return SiteField(earth, self.site())
        return Field(earth, self.drift, self.gradient, self.dipole)

    def registers(self):
        """(2, 12) register maps of chip A (X, Y) and chip B (Z, temperature)."""
        dr = RATES.index(int(self.rate))
        return [ads.standard_registers(dr, self.gain, (ads.MUX_NORMAL, ads.MUX_NORMAL), self.vref_4v),
                ads.standard_registers(dr, self.gain, (ads.MUX_NORMAL, ads.MUX_TEMP), self.vref_4v)]

    def operator(self, rng):
        """The operator's motion (motion.Motion) over the capture, from the motion's generator."""
        if self.motion == "survey":
            return self.walk()
        fdir = earth_vector(1.0, self.inclination_deg, self.declination_deg)
        return make_motion(self.motion, self.seconds + 0.1, rng, rate=self.rot_rate, coverage=self.coverage,
                           field_dir=fdir, dwell=self.dwell)

    def nt_per_code(self):
        """(3,) nominal field per code of X, Y, Z, what the firmware's scale_x/y/z must say:
        LSB = VREF / (2^23 - 1) / gain [DS §8.3.8] over the front end's nominal V/nT."""
        cfg = ads.Config(self.registers()[0])
        return np.full(3, cfg.vref / ads.FULL_SCALE_CODE / cfg.gain[0] / self.fluxgate().volts_per_nT_nominal)

    def rngs(self):
        """Independent generators: motion, sensor noise, ADC noise of chip A and B."""
        seq = np.random.SeedSequence([int(self.seed), int(self.motion_seed)])
        noise, adc_a, adc_b = (np.random.default_rng(s) for s in seq.spawn(3))
        return np.random.default_rng(int(self.motion_seed)), noise, adc_a, adc_b


def _pink(rng, seconds, rms, rate=100.0):
    """(K, 3) 1/f noise at `rate` Hz: equal-variance AR(1) terms an octave-pair apart."""
    n = int(seconds * rate) + 2
    out = np.zeros((n, 3))
    for fc in (0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0):
        a = float(np.exp(-2 * np.pi * fc / rate))
        w = rng.standard_normal((n, 3)) * np.sqrt((1 - a * a)) / (1 - a)   # unit-variance AR(1)
        out += lowpass(w, a, rng.standard_normal(3))
    return out * (rms / max(float(out.std()), 1e-12))


class AnalogChain:
    """Computes the analog grid (ADC input volts, and truth when asked) chunk by chunk.

    Chunks must follow each other (g0 of one call = g1 of the previous): the
    sensor's low-pass state and the noise stream carry over.
    """

    def __init__(self, sc, motion, noise_rng, step, phase, truth=True):
        self.sc, self.motion = sc, motion
        self.field, self.sensor = sc.field(), sc.fluxgate()
        self.noise_rng = noise_rng
        # white sensor noise on the grid, scaled so that each conversion (the
        # sinc3's weights over the grid, `phase` ticks into a grid sample) shows sc.noise rms
        w = sinc3_kernel(ads.Config(sc.registers()[0]).decimation, step, phase)
        self.grid_sigma = sc.noise / np.sqrt(np.sum(w ** 2))
        self.truth = truth
        self.lp_state = None
        self.pink = _pink(noise_rng, sc.seconds + 1, sc.pink) if sc.pink else None

    def grid(self, g0, g1, step):
        """Grid samples g0..g1-1: dict of volts (G, 3) V and temp (G,) C; with truth
        also t (G,) s, b (G, 3) nT in the sensor frame, bmag (G,) nT, q (G, 4), pos (G, 3) m."""
        t = np.arange(g0, g1) * (step / ads.F_MOD)
        q = self.motion.orientation(t)
        pos = self.motion.position(t, q) if self.truth or not self.field.uniform else None
        if self.field.uniform:
            bw = self.field.earth
        else:
            bw = self.field.at(t, pos)
        b = to_sensor(q, bw)
        if self.sc.temp_drift or self.sc.temp_profile is not None:
            temp = self.sc.temperature(t)
            r = self.sensor.reading(b, temp)
        else:
            temp = np.full(len(t), float(self.sc.temp_c))
            r = self.sensor.reading(b, float(self.sc.temp_c))
        r, self.lp_state = self.sensor.bandlimit(r, ads.F_MOD / step, self.lp_state)
        if self.grid_sigma:
            r = r + self.noise_rng.standard_normal(r.shape) * self.grid_sigma
        if self.pink is not None:
            k = t * 100.0
            i = np.minimum(k.astype(int), len(self.pink) - 2)
            f = (k - i)[:, None]
            r = r + self.pink[i] * (1 - f) + self.pink[i + 1] * f
        out = {"volts": self.sensor.to_volts(r), "temp": temp}
        if self.truth:
            bmag = np.full(len(t), np.linalg.norm(bw)) if self.field.uniform else np.linalg.norm(bw, axis=1)
            out.update(t=t, b=b, bmag=bmag, q=q, pos=pos)
        return out


# truth key in a capture <- grid array
TRUTH = (("field_true", "b"), ("magnitude_true", "bmag"), ("quaternion", "q"), ("position", "pos"),
         ("temperature_c", "temp"))


def simulate(sc, chunk_seconds=8.0, truth=True):
    """Run a scenario; returns the capture as a dict (keys: desktop/formats/capture.py).

    Parameters
    ----------
    sc : Scenario
    chunk_seconds : float
        Work in pieces of this length (bounds memory; results do not depend on it
        beyond floating-point summation order of the sensor low-pass).
    truth : bool
        Also return what really happened at each DRDY (field, orientation,
        position, temperature). The codes are the same either way.
    """
    motion_rng, noise_rng, rng_a, rng_b = sc.rngs()
    regs = sc.registers()
    cfg_a, cfg_b = ads.Config(regs[0]), ads.Config(regs[1])
    step = ads.F_MOD // sc.grid_hz()
    d = cfg_a.decimation
    first = ads.SETTLE_TICKS[cfg_a.dr]                  # START at tick 0
    chain = AnalogChain(sc, sc.operator(motion_rng), noise_rng, step, first % step, truth)
    n_total = int((sc.seconds * ads.F_MOD - first) // d) + 1
    per_chunk = max(int(chunk_seconds * cfg_a.rate), 1)
    hist = len(sinc3_kernel(d, step, first % step)) - 1   # grid samples a conversion looks back
    codes = np.empty((n_total, 4), dtype=np.int32)
    found = {key: None for key, _ in TRUTH} if truth else {}
    buf, buf_g0, g_done = None, 0, 0
    rng_a, rng_b = (rng_a, rng_b) if sc.adc_noise else (NO_NOISE, NO_NOISE)
    k_a, k_b = sc.vref_tempco()
    for k0 in range(0, n_total, per_chunk):
        n = min(per_chunk, n_total - k0)
        ticks0 = first + k0 * d
        g_last = (ticks0 + (n - 1) * d) // step
        new = chain.grid(g_done, g_last + 1, step)
        if buf is None:
            buf, buf_g0 = new, 0
        else:   # keep the last `hist` grid samples: the sinc3 window of the next conversions
            keep = max(buf_g0, g_done - hist)
            buf = {k: np.concatenate([v[keep - buf_g0:], new[k]]) for k, v in buf.items()}
            buf_g0 = keep
        g_done = g_last + 1
        kw = dict(first_tick=ticks0, n=n, step=step, grid_tick0=buf_g0 * step)
        vol = buf["volts"]
        codes[k0:k0 + n, :2] = convert(vol[:, :2], buf["temp"] if k_a else None, cfg_a, rng=rng_a,
                                       vref_tempco=k_a, **kw)
        codes[k0:k0 + n, 2:] = convert(np.c_[vol[:, 2], np.zeros(len(vol))], buf["temp"], cfg_b, rng=rng_b,
                                       vref_tempco=k_b, **kw)
        if truth:
            idx = (ticks0 + np.arange(n) * d) // step - buf_g0        # grid sample at each DRDY
            for key, src in TRUTH:
                col = buf[src][idx]
                if found[key] is None:
                    found[key] = np.empty((n_total,) + col.shape[1:])
                found[key][k0:k0 + n] = col
    a, c = chain.sensor.raw_model()
    cap = {
        "codes": codes,
        "t": (first + np.arange(n_total) * d) / ads.F_MOD,       # DRDY times exactly
        "nT_per_code": sc.nt_per_code(),
        "sensor_matrix": a,
        "sensor_offset": c,
        "registers": np.array(regs, dtype=np.uint8),
        "config": json.dumps(dict(sc.to_dict(), version=1, start_tick=0, first_drdy_tick=first)),
    }
    cap.update(found)
    if sc.motion == "survey":
        cap["line_marks"] = sc.walk().line_marks
    return cap
