"""The virtual handheld on an emulated Raspberry Pi Pico: the rp2 port's own firmware in rp2040js
(pico_board.PicoBoard) with desktop/sim's two ADS1292, button and LED on its pins (pico_world).

    with PicoHandheld(flash_dir) as hh:     # the flash is FLASH_DIR/pico.flash
        print(hh.port)                     # mpremote, pyserial and fluxcal open it as a board
        hh.act("press")                    # the operator, as virtual_handheld.ACTIONS

The operator is the other runtimes' (virtual_handheld.Hands: scripted, keys, following the LED)
and the World the same; what differs is the clock: the world moves with the emulated chip's
clock, which runs slower than the wall clock while the firmware computes (about 0.4 emulated s
per wall s on a busy core) and is paced to it while the core sleeps (idle="paced"), or jumps
over sleeps (idle="jump", for tests). There is no Pacer: nothing here can run ahead of real time.
"""

import os

from desktop.devicesim.pico_board import PicoBoard
from desktop.devicesim.pico_world import PinWorld
from desktop.devicesim.procedure import handheld_config
from desktop.devicesim.virtual_handheld import ACTIONS, Hands, live_world


class PicoHandheld:
    runtime = "micropython"

    def __init__(self, flash_dir, sensor="mag649", seed=0, motion_seed=1, idle="paced", log=None, frozen=False):
        self.world, self.operator = live_world(sensor, seed, motion_seed)
        self.scenario = self.world.scenario
        self.hands = Hands(self.world, self.operator)
        self.pins = PinWorld(self.world, self.hands)
        self.flash_file = os.path.join(os.path.abspath(flash_dir), "pico.flash")
        self.fresh = not os.path.exists(self.flash_file)   # a new board: nothing deployed yet
        # no pin held high by the runner: the world drives the button and DRDY
        self.board = PicoBoard(self.flash_file, idle=idle, high=(), world=self.pins, log=log,
                               frozen=frozen)   # frozen: the image with the firmware frozen in
        self.pacer = None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()

    @property
    def port(self):
        return self.board.port

    def start(self):
        self.board.start()
        return self

    def wiring_config(self):
        """The config.json a user writes once for this board (docs/firmware.md, Configuration)."""
        return handheld_config(self.scenario, "board:micropython")

    def act(self, action, arg=None):
        """What the operator does (virtual_handheld.ACTIONS), at the world's next news."""
        if action == "power-cycle":
            self.board.power_cycle()
        elif action not in ACTIONS:
            raise ValueError("unknown action %r (one of %s)" % (action, ", ".join(ACTIONS)))
        else:
            self.hands.act(action, arg)

    def hold_port(self, doing):
        """Clients of `port` are told the board is busy `doing` (port_gate.py); the emulator's own line."""
        return self.board.hold_port(doing)

    def release_port(self):
        self.board.release_port()

    def close(self):
        self.board.close()
