# Stand-in for CircuitPython's `digitalio` module, from docs.circuitpython.org
# shared-bindings/digitalio: DigitalInOut with direction, value, pull and drive_mode,
# switch_to_output / switch_to_input, deinit; its refusals: a pin in use, a value set while
# the direction is input, a pull set on an output, use after deinit. Not a module of the
# desktop package.
import microcontroller
import simboard

_board = simboard.board()


class Direction:
    INPUT = "INPUT"
    OUTPUT = "OUTPUT"


class Pull:
    UP = "UP"
    DOWN = "DOWN"


class DriveMode:
    PUSH_PULL = "PUSH_PULL"
    OPEN_DRAIN = "OPEN_DRAIN"


class DigitalInOut:
    def __init__(self, pin):
        microcontroller.claim(pin, "pin")
        self._pin = pin
        self._gpio = pin._gpio
        self._direction = Direction.INPUT
        self._pull = None
        self._drive = DriveMode.PUSH_PULL

    def _check(self):
        if self._pin is None:
            raise ValueError("Object has been deinitialized and can no longer be used. Create a new object.")

    def deinit(self):
        if self._pin is not None:
            microcontroller.release(self._pin)
            self._pin = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.deinit()

    def switch_to_output(self, value=False, drive_mode=DriveMode.PUSH_PULL):
        self._check()
        self._direction = Direction.OUTPUT
        self._drive = drive_mode
        self._pull = None
        _board.write(self._gpio, 1 if value else 0)

    def switch_to_input(self, pull=None):
        self._check()
        if pull not in (None, Pull.UP, Pull.DOWN):
            raise ValueError("pull must be None, Pull.UP or Pull.DOWN")
        self._direction = Direction.INPUT
        self._pull = pull

    @property
    def direction(self):
        self._check()
        return self._direction

    @direction.setter
    def direction(self, value):
        if value == Direction.OUTPUT:
            self.switch_to_output()
        elif value == Direction.INPUT:
            self.switch_to_input()
        else:
            raise ValueError("invalid direction")

    @property
    def value(self):
        self._check()
        if self._direction == Direction.OUTPUT:
            return bool(_board.driven.get(self._gpio, 0))
        return bool(_board.read(self._gpio))

    @value.setter
    def value(self, value):
        self._check()
        if self._direction == Direction.INPUT:
            raise AttributeError("Cannot set value when direction is input.")
        _board.write(self._gpio, 1 if value else 0)

    @property
    def pull(self):
        self._check()
        return self._pull

    @pull.setter
    def pull(self, pull):
        self._check()
        if self._direction == Direction.OUTPUT:
            raise AttributeError("Pull not used when direction is output.")
        self.switch_to_input(pull)
