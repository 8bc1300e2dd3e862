# Stand-in for MicroPython's `time` module on the simulated handheld, from its documentation
# (docs.micropython.org library/time): the ticks functions wrap at 2**30 as on every port
# (ticks_diff and ticks_add do the modular arithmetic), sleeps let the world's time pass (sleep_ms
# with the DRDY interrupt serviced, as the port's does),
# and time() counts from 2021-01-01 00:00 in seconds since 1970, as the rp2 port's unset RTC
# does (checked on its firmware in the emulated Pico: 1609459200 at power-on). Not a module of
# the desktop package.
import simboard

_board = simboard.board()
_PERIOD = 1 << 30
_HALF = 1 << 29
_EPOCH_2021 = 1609459200   # 2021-01-01 00:00 since 1970 at power-up: the RTC was never set


def ticks_us():
    return _board.link.t_us & (_PERIOD - 1)


def ticks_ms():
    return (_board.now_us // 1000) & (_PERIOD - 1)


def ticks_cpu():
    return ticks_us()


def ticks_add(ticks, delta):
    return (ticks + delta) & (_PERIOD - 1)


def ticks_diff(ticks1, ticks2):
    return ((ticks1 - ticks2 + _HALF) & (_PERIOD - 1)) - _HALF


def sleep_us(us):
    _board.sleep_us(us)


def sleep_ms(ms):
    _board.sleep_ms(ms)


def sleep(seconds):
    _board.sleep_us(int(seconds * 1000000))


def time():
    return _EPOCH_2021 + _board.now_us // 1000000


def time_ns():
    return (_EPOCH_2021 * 1000000 + _board.now_us) * 1000
