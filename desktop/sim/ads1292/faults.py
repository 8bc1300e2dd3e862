"""Faults injected into an emulated ADS1292 (docs/simulator.md, "Fault injection").

A chip that does not answer, a stuck DRDY, corrupted status words or bits, an
input beyond full scale, an oscillator off frequency. :meth:`ADS1292.set_fault`
switches them at run time; this module says what each one is and does to the
bytes, drawing from the chip's fault stream (never its noise stream).
"""

from fractions import Fraction

import numpy as np

FAULTS = ("absent-0x00", "absent-0xff", "drdy-stuck-high", "drdy-stuck-low",
          "status-corrupt", "bit-flips", "clipping", "clock-drift")
# `rate` of a fault when none is given: probability per frame (status-corrupt), per bit
# (bit-flips); the oscillator's relative frequency error (clock-drift)
DEFAULT_FAULT_RATES = {"status-corrupt": 0.01, "bit-flips": 1e-4, "clock-drift": 0.005}
# faults under which the DRDY pin makes no falling edges
DRDY_DEAD = ("absent-0x00", "absent-0xff", "drdy-stuck-high", "drdy-stuck-low")


def checked_rate(fault, rate):
    """`rate` for `fault` (its default when None); ValueError for an unknown fault or a
    rate out of range."""
    if fault is not None and fault not in FAULTS:
        raise ValueError("unknown fault %r (one of %s)" % (fault, ", ".join(FAULTS)))
    rate = DEFAULT_FAULT_RATES.get(fault, 0.01) if rate is None else float(rate)
    if fault == "clock-drift":
        if not -0.5 < rate < 0.5:
            raise ValueError("clock-drift rate is a relative frequency error in (-0.5, 0.5), got %r" % rate)
    elif not 0.0 <= rate <= 1.0:
        raise ValueError("fault rate is a probability in [0, 1], got %r" % rate)
    return rate


def oscillator_ratio(fault, rate):
    """The oscillator's frequency over the nominal one, as an exact fraction (so that
    every event still lands on a whole tick)."""
    return Fraction(1.0 + rate).limit_denominator(1_000_000) if fault == "clock-drift" else Fraction(1)


def corrupt_status(status, rng, rate):
    """A status word as "status-corrupt" leaves it: with probability `rate` its 1100
    header reads 1111 and its low 13 bits, always 0 on a real chip, are random."""
    if rng.random() < rate:
        status ^= 0x300000 | int(rng.integers(1 << 13))
    return status


def dout_bytes(out, fault, rng, rate):
    """What the host reads on DOUT under `fault`, given the bytes the chip shifted out."""
    if fault == "absent-0x00":
        return bytes(len(out))
    if fault == "absent-0xff":
        return b"\xff" * len(out)
    if fault == "bit-flips":
        bits = np.unpackbits(np.frombuffer(bytes(out), np.uint8))
        bits ^= (rng.random(bits.size) < rate).astype(np.uint8)
        out = np.packbits(bits).tobytes()
    return bytes(out)
