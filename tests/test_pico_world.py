"""The simulated world on the emulated Pico's pins (desktop/devicesim/pico_world.py, pico/pins.mjs):
desktop/sim's ADS1292 answer the rp2 firmware's own SPI and pins, on the emulated clock."""

import subprocess
import sys

import pytest

from desktop.sim.ads1292.registers import F_MOD, SETTLE_TICKS
from tests.interpreters import need

MPREMOTE = [sys.executable, "-m", "mpremote"]

# the HAL's wiring (device/config.py's defaults) and bus settings (device/hal_micropython.py)
SETUP = """
from machine import SPI, Pin
import time
cs0 = Pin(17, Pin.OUT, value=1); cs1 = Pin(20, Pin.OUT, value=1)
reset = Pin(26, Pin.OUT, value=1); start = Pin(22, Pin.OUT, value=0)
drdy = Pin(21, Pin.IN, Pin.PULL_UP)
spi = SPI(0, 1_000_000, polarity=0, phase=1, sck=Pin(18), mosi=Pin(19), miso=Pin(16))
def cmd(cs, b):
    cs(0); spi.write(b); time.sleep_us(8); cs(1)
"""


@pytest.fixture
def world_board(tmp_path):
    need("rp2-pico")
    from desktop.devicesim.pico_board import PicoBoard
    from desktop.devicesim.pico_world import PinWorld
    from desktop.devicesim.virtual_handheld import live_world

    world, _operator = live_world()
    pins = PinWorld(world)
    with PicoBoard(str(tmp_path / "pico.flash"), idle="jump", high=(), world=pins) as board:
        yield board, pins


def run(port, code):
    r = subprocess.run(MPREMOTE + ["connect", port, "exec", SETUP + code], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def test_the_chips_answer_the_rp2_spi_and_drdy_comes_at_the_configured_rate(world_board):
    board, pins = world_board
    out = run(board.port, """
time.sleep_ms(2)
cmd(cs0, b'\\x11'); cmd(cs1, b'\\x11')               # SDATAC: registers
id0 = bytearray(3); cs0(0); spi.write_readinto(b'\\x20\\x00\\x00', id0); time.sleep_us(8); cs0(1)
id1 = bytearray(3); cs1(0); spi.write_readinto(b'\\x20\\x00\\x00', id1); time.sleep_us(8); cs1(1)
cmd(cs0, b'\\x10'); cmd(cs1, b'\\x10')               # RDATAC
n = [0]
def edge(p):
    n[0] += 1
drdy.irq(edge, Pin.IRQ_FALLING, hard=True)
start(1); time.sleep_ms(100); start(0)
f = bytearray(9); cs0(0); spi.readinto(f, 0); cs0(1)
import machine
machine.mem32[0x40068000] = 0x107; machine.mem32[0x40068000] = 0    # the profiling port: part 7, once
print('ids', hex(id0[2]), hex(id1[2]), 'edges', n[0], 'status', hex(f[0] >> 4))
""")
    words = out.split()
    assert words[1:3] == ["0x53", "0x53"], out          # ADS1292's ID register [DS 8.6.1.1]
    # 500 SPS at power-on (CONFIG1 = 0x02 [DS 8.6.1.2]): the first DRDY tSETTLE after START, then
    # one every 2 ms of emulated time until START falls 100 ms later; the last may fall in the
    # few microseconds the interpreter takes between start(1) and the sleep, and after it
    settle = SETTLE_TICKS[2] / F_MOD
    expected = int((0.100 - settle) / 0.002) + 1
    assert expected <= int(words[4]) <= expected + 1, out
    assert words[6] == "0xc", out                       # a frame's status word starts 1100 [DS 8.5.1.9]
    assert pins.mismatches == 0 and pins.counts["S"] > 0
    # the runner's count by part (desktop/devicesim/pico/parts.mjs): every edge entered the GPIO
    # bank's interrupt (exception 16 + 13), and the one named part was entered once
    calls = board.figures()["parts"]["calls"]
    assert calls.get("irq29", 0) >= int(words[4]) and calls.get("part7") == 1, calls


def test_an_allocation_in_the_hard_drdy_interrupt_fails_as_on_a_board(world_board):
    board, _pins = world_board
    out = run(board.port, """
got = []
def handler(p):
    got.append([1, 2, 3])                            # a new list: the heap is locked here
drdy.irq(handler, Pin.IRQ_FALLING, hard=True)
start(1); time.sleep_ms(20); start(0)
drdy.irq(None)
print('handled', len(got))
""")
    assert "MemoryError" in out and "handled 0" in out, out
