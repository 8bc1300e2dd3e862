"""The board HALs on the interpreters of their boards, over stand-ins for the boards' C modules.

device/hal_micropython.py runs on single-precision MicroPython (as rp2, esp32 and stm32
compute) and device/hal_circuitpython.py on CircuitPython's own interpreter (30-bit floats,
polled DRDY), each deployed as the runtime's manifest says, booted as a board boots
(boot.py, then main.py / code.py), driving machine / board, busio, digitalio, keypad,
supervisor, usb_cdc and storage stand-ins (desktop/devicesim/stand-ins) wired to the
emulated ADS1292. The stand-ins refuse what the real modules refuse, so a misuse fails here
as it would on a board. What they cannot show: the CPU's own time (main-loop work costs no
world time here), the pins' electrical timing, the real SPI clock's edges.
"""

import pytest

from desktop.devicesim.procedure import calibrate_and_verify
from desktop.devicesim.runners import BoardDevice, DeviceDied
from desktop.devicesim.world import make_world
from tests.device_bounds import spin_ptp_bound
from tests.interpreters import heap_bytes, need


@pytest.mark.parametrize("interpreter", ["micropython-float32", "circuitpython"])
def test_board_hal_completes_a_calibration_cycle(interpreter, tmp_path):
    need(interpreter)
    r = calibrate_and_verify(kind="board:" + interpreter, root=str(tmp_path), rotate_s=60.0, spin_s=10.0)
    cal = r["cal"]
    assert cal["state"] == "done" and cal["saved"] is True, cal
    assert r["rotated_s"] <= 16.0                      # ready by the third provisional solve
    assert r["boot"]["calibrated"] and r["boot"]["cal_source"] == "json"   # survived the power cycle
    assert r["ptp_cal"] <= spin_ptp_bound(r["world"].scenario, len(r["spin_f_cal"])), r["ptp_cal"]
    st = r["status"]
    assert st["overflow"] == 0 and st["badsync"] == 0 and st["gaps"] == 0
    # gc.mem_free of the heap the runner gave the board's interpreter, the firmware in it: some left, not all
    assert 0 < st["mem_free"] < heap_bytes(interpreter), st["mem_free"]


MISUSE = [
    # (interpreter, snippet, what the real module says)
    ("circuitpython", "import board, digitalio\np = digitalio.DigitalInOut(board.GP15)\np.value = True",
     "Cannot set value when direction is input"),
    ("circuitpython", "import board, busio\ns = busio.SPI(board.GP18, MOSI=board.GP19, MISO=board.GP16)\ns.write(b'x')",
     "Function requires lock"),
    ("circuitpython", "import board, busio\ns = busio.SPI(board.GP18)\ns.configure(baudrate=1000000)",
     "Function requires lock"),
    ("circuitpython", "import busio\nbusio.SPI(18)", "must be of type Pin"),
    ("circuitpython", "import board, digitalio\na = digitalio.DigitalInOut(board.GP17)\nb = digitalio.DigitalInOut(board.GP17)",
     "in use"),
    ("circuitpython", "import board, busio\ns = busio.SPI(board.GP18)\ns.try_lock()\ns.write_readinto(bytearray(2), bytearray(3))",
     "buffer slices must be of equal length"),
    ("circuitpython", "import usb_cdc\nusb_cdc.enable(data=True)", "Cannot change USB devices now"),
    ("circuitpython", "import board, keypad\nkeypad.Keys((board.GP15,), pull=True)", "missing required keyword argument"),
    ("micropython-float32", "import machine\nmachine.SPI(0, baud=1000000)", "extra keyword arguments given"),
    ("micropython-float32", "import machine\nmachine.SPI(0, sck=machine.Pin(5))", "bad SCK pin"),
    ("micropython-float32", "import machine\nmachine.SPI(2)", "doesn't exist"),
    ("micropython-float32", "import machine\nmachine.Pin(40)", "invalid pin"),
    ("micropython-float32", "import machine\ns = machine.SPI(0)\ns.write_readinto(bytearray(2), bytearray(3))",
     "buffers must be the same length"),
]


@pytest.mark.parametrize("interpreter, snippet, message", MISUSE, ids=[m[2][:24] for m in MISUSE])
def test_stand_ins_refuse_what_the_board_refuses(interpreter, snippet, message, tmp_path):
    need(interpreter)
    w = make_world(serial=None, motion="stationary", seconds=1.0)
    program = "import simboard\nsimboard.board().phase = 'main'\n" + snippet + "\nprint('no error')\n"
    dev = BoardDevice(w, str(tmp_path), interpreter=interpreter, program=program)
    try:
        with pytest.raises(DeviceDied) as info:
            dev.run_until(0.5)
            dev.run_until(1.0)   # a program that ends without an error still ends the run
            raise AssertionError("the snippet ran: %r" % w.lines())
        assert message in str(info.value), str(info.value)
    finally:
        dev.close()
