"""The simulation link's wire format, named once for both ends.

The firmware under the `micropython` executable reaches the emulated chips
through a pipe (its stdin/stdout with the simulation HAL, two extra file
descriptors when the board's own HAL runs on stand-ins for the board's C
modules): sim_link.py writes these messages, the desktop's
desktop/devicesim/link_host.py answers them. Little endian throughout.

Request: op(1) arg(1) len(2) payload. Replies only where shown.
"""

try:
    from micropython import const
except ImportError:  # CPython (the desktop end): const is the identity
    def const(x):
        return x

HEADER = const(4)          # op, arg, len (u16)

OP_XFER = const(0x58)      # arg chip, len n, n bytes out -> n bytes in (one SPI transaction, CS framed)
OP_READ = const(0x5A)      # arg chip, len n -> n bytes in (DIN held low)
NO_CHIP = const(0xFF)      # chip of an XFER/READ with every CS high: SCLK runs, nobody answers
OP_IDLE = const(0x49)      # -> IDLE_REPLY: t_us u32, flags u8, pending u16, 0
OP_STALL_IDLE = const(0x4A)  # len 4, u32 us -> IDLE_REPLY, returning after at most us (a stall
                             # with a hard IRQ: the host's run budget does not stop it)
OP_STALL = const(0x54)     # arg 1 = polled, len 4, u32 us: a charged stall starts (no reply);
                           # polled: the host lets the time pass
OP_SERIAL_READ = const(0x52)   # -> len u16, then the bytes from the host
OP_SERIAL_WRITE = const(0x57)  # len n, n bytes to the host (no reply)
OP_PIN = const(0x50)       # arg pin, len value (no reply)
OP_SLEEP = const(0x53)     # len 4, u32 us busy wait (no reply)
OP_BAUD = const(0x42)      # len 4, u32 SPI clock in Hz, sets the emulator's byte time (no reply)
OP_POLL = const(0x51)      # len 4, u32 us -> IDLE_REPLY: a pin read that takes time: returns at once if
                           # chip 0's DRDY is low, else when it falls or after at most us

IDLE_REPLY = const(8)

PIN_START = const(0)
PIN_RESET = const(1)
PIN_LED = const(2)

# flags of an idle reply
F_DRDY = const(1)          # chip 0's DRDY fell since the last idle
F_BUTTON = const(2)        # button pressed
F_SERIAL = const(4)        # serial bytes waiting (`pending` of them)
F_QUIT = const(8)          # power off: the main loop returns
F_DRDY_LOW = const(16)     # chip 0's DRDY pin is low now (a level, for polling boards)

T_MASK = const(0x3FFFFFFF)  # t_us wraps like MicroPython's ticks: a power-of-two period
