# Stand-in for CircuitPython's `board` module of a Raspberry Pi Pico, from its pin list
# (docs.circuitpython.org, Raspberry Pi Pico): GP0..GP28 and LED (GP25), the same Pin objects
# as microcontroller.pin. Not a module of the desktop package.
import microcontroller as _mc

for _n in range(29):
    globals()["GP%d" % _n] = getattr(_mc.pin, "GPIO%d" % _n)
LED = GP25  # noqa: F821 (defined just above)
board_id = "raspberry_pi_pico"
