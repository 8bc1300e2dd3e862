# Stand-in for CircuitPython's `time` module, from docs.circuitpython.org shared-bindings/time:
# monotonic() and monotonic_ns() from power-up (monotonic_ns needs long ints, which this build
# has), sleep(seconds) letting the world's time pass, time() from 2000-01-01 as a board without
# a set RTC. Not a module of the desktop package.
import simboard

_board = simboard.board()


def monotonic_ns():
    return _board.now_us * 1000


def monotonic():
    return _board.now_us / 1000000


def sleep(seconds):
    _board.sleep_us(int(seconds * 1000000))


def time():
    return 946684800 + _board.now_us // 1000000
