"""The emulated Pico (desktop/devicesim/pico_board.py): MicroPython's rp2 firmware in rp2040js,
reached with the real mpremote over a pseudo-terminal, its flash kept in a file.

The runner idles by jumping to the next timer (idle="jump") except where mpremote's own wall-clock
polls need idle time spent as wall time.
"""

import os
import signal
import subprocess
import sys
import time

import pytest

from desktop.firmware.mpy import ARCHS
from tests.interpreters import need

MPREMOTE = [sys.executable, "-m", "mpremote"]
FLASH = 2 * 1024 * 1024       # RPI_PICO's flash
FS_OFFSET = 0xA0000           # its littlefs partition (ports/rp2/boards/RPI_PICO)


@pytest.fixture
def pico(tmp_path):
    need("rp2-pico")
    from desktop.devicesim.pico_board import PicoBoard

    boards = []

    def start(flash=None, idle="jump"):
        board = PicoBoard(flash or str(tmp_path / "pico.flash"), idle=idle).start()
        boards.append(board)
        return board

    yield start
    for b in boards:
        b.close()


def mpremote(port, *args, timeout=120):
    r = subprocess.run(MPREMOTE + ["connect", port] + list(args), capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def test_boots_the_rp2_firmware_on_an_armv6m_core(pico):
    board = pico()
    out = mpremote(board.port, "exec", "import sys, gc; print(sys.platform, sys.implementation._machine);"
                   "print(sys.implementation._mpy >> 10, gc.mem_free() > 200000)")
    assert "rp2 Raspberry Pi Pico with RP2040" in out
    arch, heap_ok = out.split()[-2:]
    assert ARCHS[int(arch)] == "armv6m" and heap_ok == "True", out   # _mpy's bits 10..: the native code


def test_machine_freq_sets_the_emulated_clock(pico):
    """rp2040js derives clk_sys from the PLL; the runner spends 1/clk_sys of emulated time per
    cycle, so a loop's instructions take 125/48 times as long at 48 MHz. Slack: the USB
    interrupts the loop may meet (tens of us over ~0.1 s) and the 1 us tick, under 2 %."""
    board = pico()
    out = mpremote(board.port, "exec", "import machine, time\n"
                   "def spin():\n t0 = time.ticks_us()\n for i in range(20000): pass\n"
                   " return time.ticks_diff(time.ticks_us(), t0)\n"
                   "a = spin(); machine.freq(48000000); b = spin(); f = machine.freq(); machine.freq(125000000)\n"
                   "print(a, b, f, spin())")
    at_125, at_48, freq, again = (int(w) for w in out.split()[-4:])
    assert freq == 48000000
    assert abs(at_48 / at_125 - 125 / 48) < 0.02 * 125 / 48, out
    assert abs(again / at_125 - 1) < 0.02, out
    assert board.figures()["clk_sys_hz"] == 125000000


def test_files_survive_machine_reset_and_a_restart_of_the_emulator(pico, tmp_path):
    flash = str(tmp_path / "pico.flash")
    src = tmp_path / "note.txt"
    src.write_text("kept in flash\n")
    board = pico(flash)
    mpremote(board.port, "fs", "cp", str(src), ":note.txt")
    n = len(board.events)
    mpremote(board.port, "reset")                  # machine.reset(): the watchdog, the chip re-created
    board.wait_event("boot (watchdog)", after=n)
    assert mpremote(board.port, "fs", "cat", ":note.txt").strip() == "kept in flash"
    board.close()
    assert os.path.getsize(flash) == FLASH
    board = pico(flash)                                                   # a new runner, the same file
    assert mpremote(board.port, "fs", "cat", ":note.txt").strip() == "kept in flash"


@pytest.mark.parametrize("damage", ["truncated", "garbage"])
def test_a_damaged_flash_file_comes_up_formatted_and_says_so(pico, tmp_path, damage):
    flash = tmp_path / "pico.flash"
    rng = __import__("random").Random(1)
    if damage == "truncated":
        flash.write_bytes(b"\xff" * 4096)          # cut short: the rest reads as erased flash
        said = "is 4096 bytes, not %d" % FLASH
    else:                                          # noise over the whole filesystem
        flash.write_bytes(b"\xff" * FS_OFFSET + bytes(rng.getrandbits(8) for _ in range(FLASH - FS_OFFSET)))
        said = "holds no littlefs"
    board = pico(str(flash))
    board.wait_event(said, timeout=10)
    out = mpremote(board.port, "exec", "import os; open('x', 'w').write('ok'); print(os.listdir())")
    assert "['x']" in out
    assert board.running()


def test_the_emulator_killed_mid_stream_hangs_up_the_port_and_leaves_no_process(pico):
    serial = pytest.importorskip("serial")
    board = pico()
    mpremote(board.port, "exec", "print('up')")
    with serial.Serial(board.port, timeout=5) as s:
        s.write(b"\x03\x02")                       # to the friendly REPL
        s.write(b"while True: print('x' * 60)\r\r")       # a blank line ends the loop's block
        assert b"x" * 60 in s.read(400)
        os.killpg(board.proc.pid, signal.SIGKILL)
        t0 = time.monotonic()
        with pytest.raises(serial.SerialException):
            while time.monotonic() - t0 < 5:
                s.read(4096)
    board.wait_event("stopped", timeout=5)
    with pytest.raises(ProcessLookupError):
        os.killpg(board.proc.pid, 0)


def test_close_ends_the_runner_and_its_process_group(pico):
    board = pico()
    pid = board.proc.pid
    board.close()
    with pytest.raises(ProcessLookupError):
        os.killpg(pid, 0)


def test_the_stand_ins_refusals_are_the_rp2_port_s_own(pico):
    """Each refusal the `machine` stand-in copies (test_device_boards.MISUSE) is what the rp2
    firmware itself says; and its unset clock reads 2021-01-01 in seconds since 1970, as the
    `time` stand-in's does (the HAL takes anything before 2022 for a clock never set)."""
    from tests.test_device_boards import MISUSE

    board = pico()
    for interpreter, snippet, message in MISUSE:
        if interpreter != "micropython-float32":
            continue
        r = subprocess.run(MPREMOTE + ["connect", board.port, "exec", snippet], capture_output=True, text=True,
                           timeout=120)
        assert message in r.stdout + r.stderr, (snippet, r.stdout + r.stderr)
    out = mpremote(board.port, "exec", "import time; print(time.time() // 86400)")
    assert int(out) == 1609459200 // 86400, out


def test_pio_runs_between_its_waits_and_a_program_that_never_waits_is_stopped(pico):
    """The runner runs an enabled state machine to its next wait whenever the core touches its
    PIO block or an input pin changes (thing 5 in runner.mjs: fluxcal's DRDY counter waits on
    DRDY's edges). An echo through the FIFOs answers at once; a loop with no wait, which runs
    free on a real RP2040, is stopped with a line on the runner's stderr, not left to run in
    rp2040js's own timer slices apart from the emulated clock."""
    board = pico()
    out = mpremote(board.port, "exec", "import rp2\n"
                   "@rp2.asm_pio()\n"
                   "def echo():\n pull()\n mov(isr, invert(osr))\n push()\n"
                   "sm = rp2.StateMachine(0, echo)\nsm.active(1)\n"
                   "print([sm.get() for v in (0, 7, 0x12345678) if sm.put(v) is None])\n"
                   "@rp2.asm_pio()\n"
                   "def spin():\n wrap_target()\n nop()\n wrap()\n"
                   "rp2.StateMachine(1, spin).active(1)\nprint('spun')")
    assert "[4294967295, 4294967288, 3989547399]" in out and "spun" in out, out
    board.wait_event("PIO0: a state machine ran 256 instructions without waiting: stopped", timeout=30)
