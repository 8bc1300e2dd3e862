"""The HAL contract: everything the firmware asks of a board, written once.

Each runtime has its HAL, a `Board` class that subclasses this one:
hal_micropython.py (machine.SPI, Pin.irq), hal_circuitpython.py (busio,
digitalio, keypad; DRDY polled) and sim/hal_sim.py (a link to the desktop's
emulated ADS1292). Nothing above the HAL knows which runtime it runs on.
A method a HAL forgets raises NotImplementedError naming it; the defaults
below are what real hardware does.

Timing facts cited: [DS] = ADS1292 datasheet SBAS502C.
"""

# a button closing timed by an interrupt is taken by the poll that finds it (button.py) up to this
# long after: a main-loop pass or two (app.py), never a stale one from a release's bounce
EDGE_MS = 100


class Board:
    REG_BAUD = 1000000    # SCLK during register access: <= 2 fCLK = 1.024 MHz [DS §8.3.7]
    DATA_BAUD = 8000000   # RDATAC frame reads may run up to 20 MHz (tSCLK 50 ns) [DS §6.6]
    root = ""             # folder of cal.json, config.json and the logs ("" = the flash's root)
    name = "board"        # runtime name reported by `version`
    # True when the DRDY handler runs while the core sleeps in sleep_ms (an interrupt, hard or
    # scheduled): the main loop then sleeps between passes (app.App.wait). False where idle()
    # itself services DRDY (a polling HAL, the simulator's link).
    sleeps_with_irq = False
    # True where the firmware polls DRDY (no user interrupts: CircuitPython; the simulator's
    # polled board): conversions pass unseen while the main loop is busy, a gap every few
    # samples, so the de-lag by the ADC's response (config delag_adc "auto") stays off there.
    polls_drdy = False

    # What a native DRDY handler (device/native/drdy.c) calls to read a frame as spi_readinto
    # does: a list [cs0, cs1, readinto] of callables that allocate nothing (cs(0), cs(1): the
    # chip select's level; readinto(buf, 0)), kept current when the bus changes. None: the HAL
    # has none (CircuitPython polls DRDY; the simulator), and the pure-Python handler runs.
    drdy_bus = None

    # ****** SPI bus: two chips, one chip select each, mode 1 (CPOL 0, CPHA 1) ******
    def set_spi_rate(self, hz):
        raise NotImplementedError("set_spi_rate")

    def spi_write(self, chip, buf, n):
        """CS of `chip` low, clock out buf[:n], CS high."""
        raise NotImplementedError("spi_write")

    def spi_write_readinto(self, chip, wbuf, rbuf, n):
        """CS low, clock out wbuf[:n] while reading rbuf[:n], CS high."""
        raise NotImplementedError("spi_write_readinto")

    def spi_readinto(self, chip, buf):
        """CS low, clock in len(buf) bytes with DIN low, CS high.

        Called from the DRDY handler: must not allocate (a hard IRQ's rule).
        """
        raise NotImplementedError("spi_readinto")

    # ****** pins ******
    def set_start(self, v):
        """The START line shared by both chips."""
        raise NotImplementedError("set_start")

    def set_reset(self, v):
        """The PWDN/RESET line shared by both chips (low resets, [DS §8.5.1.8])."""
        raise NotImplementedError("set_reset")

    def led(self, on):
        raise NotImplementedError("led")

    def button(self):
        """True while the button is pressed (raw level; button.py debounces)."""
        raise NotImplementedError("button")

    button_edges = False    # True where button_edge times the presses (a pin interrupt)

    def button_edge(self, now):
        """The ticks_ms at which the button last closed, where an interrupt times it and that was
        at most EDGE_MS before `now` (hal_micropython.py); else `now`, the poll's own time."""
        return now

    def attach_drdy(self, handler, rate=0, on_gap=None):
        """Call handler(pin) on each DRDY falling edge of chip 0.

        A HAL with interrupts ignores rate and on_gap. A polling HAL (no user
        interrupts) calls on_gap(frames) from the main loop, before the
        handler, when conversions at `rate` SPS passed unseen.
        """
        raise NotImplementedError("attach_drdy")

    def count_drdy(self, skip, window):
        """Count `skip` DRDY falls of every `skip + window` in hardware and call the handler
        attach_drdy gets only on the other `window`, from the next fall after each attach (or
        after this call, if one is attached); True where the board does (the handler then
        accounts the skipped conversions itself: acquisition.py). Without a hardware counter,
        False: the handler sees every conversion."""
        return False

    # ****** time ******
    def ticks_ms(self):
        raise NotImplementedError("ticks_ms")

    def ticks_diff(self, a, b):
        """a - b for two ticks_ms values, across the wrap."""
        raise NotImplementedError("ticks_diff")

    def sleep_us(self, us):
        raise NotImplementedError("sleep_us")

    def sleep_ms(self, ms):
        self.sleep_us(ms * 1000)

    def idle(self):
        """Wait for the next event (a DRDY, at most 1/rate s away, serial or button)."""
        raise NotImplementedError("idle")

    def time(self):
        """Wall-clock seconds since 1970, or None when the board does not know."""
        return None

    def busy(self, what, n=1):
        """The main loop just did n units of work `what` ("solve", "sample_cal",
        "sample"). Nothing to do on hardware, where the time really passed; the
        simulation charges it as chip time (sim/hal_sim.py)."""

    def quit_requested(self):
        """True when the main loop should return (the simulation's power-off)."""
        return False

    # ****** the watchdog ******
    def watchdog_start(self, ms):
        """Start the chip's watchdog with a timeout of ms, if this board has one the firmware can
        hand back to the REPL (hal_micropython.py: the RP2040's); True when started. From then on
        watchdog_feed() must come within ms, or the chip resets. None here: False."""
        return False

    def watchdog_feed(self):
        """Restart the watchdog's count (the main loop, once a pass). Nothing without one."""

    def reset_by_watchdog(self):
        """True when this boot follows a reset by the watchdog's timeout (a hung firmware), not a
        power-on or a reset asked for (machine.reset()). False when the board cannot tell."""
        return False

    def hand_back(self):
        """The main loop has returned (the `repl` command, or the simulation's power-off):
        give the board back to the REPL. A HAL undoes here what it took from the REPL
        (hal_micropython.py: the DRDY interrupt, Ctrl-C; a watchdog that cannot be stopped is
        fed from a timer from then on). Nothing by default."""

    # ****** serial (USB CDC) ******
    def serial_read(self):
        """Bytes waiting from the host, or None; never blocks."""
        raise NotImplementedError("serial_read")

    def serial_write(self, data):
        raise NotImplementedError("serial_write")
