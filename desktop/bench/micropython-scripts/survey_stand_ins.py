# Stand-ins around device/survey.py's Output where it runs alone (pico_survey.py here,
# tests/micropython/survey_exact.py): the board, the serial line, the ADC's die temperature
# and a spike screen that passes every sample, as the window sums given.


class Board:
    root = ""
    polls_drdy = False    # device/hal.py's contract: DRDY an interrupt

    def ticks_ms(self):
        return 0


class Line:
    """The serial line (protocol.Protocol's send_line): each event line, as bytes, to `out`."""

    def __init__(self, out):
        self.out = out

    def send_line(self, line):
        self.out(line)


class Die:
    def __init__(self, temp):
        self.temp = temp

    def temperature_c(self, code):
        return self.temp


class Passes:
    clipped = 0
    spikes = 0

    def push(self, sx, sy, sz, st):
        self.x, self.y, self.z, self.t = sx, sy, sz, st
        return True

    def reset(self):
        pass
