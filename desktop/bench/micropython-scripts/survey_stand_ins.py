# Stand-ins around device/survey.py's Output where it runs alone (pico_survey.py here,
# tests/micropython/survey_exact.py): the board, the serial line, the ADC's die temperature
# and a spike screen that passes every sample, as the window sums given.


class Board:
    root = ""
    polls_drdy = False    # device/hal.py's contract: DRDY an interrupt

    def ticks_ms(self):
        return 0

    def serial_write(self, data):     # protocol.Protocol's port: the bytes taken
        pass


class Line:
    """The serial line (protocol.Protocol's send_line): each event line, as bytes, to `out`; and a
    tree's before 2026-12-03 (pico_survey.py --source), its event: the members' text, not framed."""

    def __init__(self, out):
        self.out = out

    def send_line(self, line):
        self.out(line)

    def event(self, name, fields, members=""):
        self.out(members or fields)


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
