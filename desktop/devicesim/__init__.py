"""The firmware (device/) on simulated hardware: the handheld's World around the emulated
chips, the runners (in CPython, or in the `micropython` executable over a pipe link),
the paper's field procedure scripted, a pyserial client, and a MicroPython board on a
pseudo-terminal for mpremote."""
