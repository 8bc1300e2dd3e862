# Stand-in for CircuitPython's `supervisor` module, from docs.circuitpython.org
# shared-bindings/supervisor: ticks_ms() counts milliseconds from power-up and wraps at 2**29
# (so that it stays a small int); runtime.serial_bytes_available / serial_connected describe
# the USB console (here the process's stdin). Not a module of the desktop package.
import select
import sys

import simboard

_board = simboard.board()
_poll = select.poll()
_poll.register(sys.stdin, select.POLLIN)


def ticks_ms():
    return (_board.now_us // 1000) & ((1 << 29) - 1)


class _Runtime:
    serial_connected = True

    @property
    def serial_bytes_available(self):
        return 1 if _poll.poll(0) else 0


runtime = _Runtime()


def reload():
    raise SystemExit(0)
