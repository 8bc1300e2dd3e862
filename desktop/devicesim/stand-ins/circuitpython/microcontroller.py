# Stand-in for CircuitPython's `microcontroller` module on the simulated handheld (an RP2040
# board), from docs.circuitpython.org shared-bindings/microcontroller: Pin objects (one per
# GPIO, compared by identity), cpu, reset(). Not a module of the desktop package.
import simboard


class Pin:
    def __init__(self, gpio):
        self._gpio = gpio

    def __repr__(self):
        return "board.GP%d" % self._gpio


class _Pins:
    pass


pin = _Pins()
for _n in range(29):
    setattr(pin, "GPIO%d" % _n, Pin(_n))


class _Processor:
    frequency = 125000000
    temperature = 27.0


cpu = _Processor()


def reset():
    # The board restarts: the interpreter stops where it is and the runner powers it on again
    # (SystemExit would not do under `-i`, whose REPL catches it).
    import os
    os.system("kill -9 $PPID")
    raise SystemExit(0)


def claim(p, owner):
    """Mark pin p in use by owner; ValueError as CircuitPython's 'GPn in use'."""
    if not isinstance(p, Pin):
        raise TypeError("%s must be of type Pin, not %s" % (owner, type(p).__name__))
    claimed = simboard.board().claimed
    if p._gpio in claimed:
        raise ValueError("%r in use" % p)
    claimed[p._gpio] = owner


def release(p):
    simboard.board().claimed.pop(p._gpio, None)
