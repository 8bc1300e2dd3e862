"""Several emulated ADS1292 on one SPI bus: separate chip selects, a shared START."""

from desktop.sim.ads1292.registers import F_MOD


class SPIBus:
    """Several chips on one SPI bus with separate chip selects and a shared START.

    Every byte clocked reaches every chip: the selected one answers, the others
    only see SCLK (their DRDY returns high [DS §8.5.1.6]) and time passes for all.
    """

    def __init__(self, chips):
        self.chips = list(chips)

    def select(self, index):
        """Drive CS of chip `index` low (None: all high)."""
        for i, chip in enumerate(self.chips):
            chip.select(i == index)

    def transfer(self, data):
        """Full-duplex transfer with the selected chip; 0xFF if none is selected."""
        data = bytes(data)
        selected = [c for c in self.chips if c.selected]
        if len(selected) > 1:
            for c in selected:
                c._violate("bus contention: more than one chip selected")
        out = None
        for chip in self.chips:
            if chip.selected:
                got = chip.transfer(data)
                out = got if out is None else bytes(a & b for a, b in zip(out, got))
            else:
                chip.clock(len(data))
        return out if out is not None else b"\xff" * len(data)

    @property
    def start(self):
        return self.chips[0].start

    @start.setter
    def start(self, level):
        for chip in self.chips:
            chip.start = level

    def advance(self, seconds):
        """Let time pass for every chip."""
        for chip in self.chips:
            chip.advance(seconds)

    def wait_drdy(self, index=0, timeout=1.0):
        """Advance all chips to the next DRDY of chip `index` (the one wired to
        the MCU); return the seconds waited. TimeoutError as ADS1292.wait_drdy,
        with every chip at chip `index`'s deadline tick."""
        chip = self.chips[index]
        start = chip.tick
        try:
            tick = chip.next_drdy_tick(timeout)
        except TimeoutError:                 # chip is at its deadline tick: the others follow
            for other in self.chips:
                if other is not chip:
                    other.advance_to_tick(chip.tick)
            raise
        for c in self.chips:
            c.advance_to_tick(tick)
        return (tick - start) / F_MOD
