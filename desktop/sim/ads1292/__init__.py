"""The TI ADS1292, emulated from its datasheet ([DS] = SBAS502C).

- registers.py: the datasheet's numbers (clocks, commands, register map, rates,
  gains, frames, temperature sensor) and `Config`, a register map decoded.
- convert.py: conversion results of a running chip, vectorised over a capture.
- chip.py: one chip byte by byte on its SPI bus (`ADS1292`): pins, time,
  frames, the SPI bytes; strict about timing and fixed bits.
- commands.py: the chip's command decoder and register file (mixed into `ADS1292`).
- clock.py: the chip's oscillator and the DRDY schedule it times.
- analog.py: the analog world feeding a chip (inputs, die temperature, noise),
  turned into codes by convert.py, batched.
- faults.py: the faults a chip can be given (absent, stuck DRDY, corrupt bits, ...).
- bus.py: several chips on one bus with a shared START (`SPIBus`).
"""
