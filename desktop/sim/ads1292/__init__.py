"""The TI ADS1292, emulated from its datasheet ([DS] = SBAS502C).

- registers.py: the datasheet's numbers (clocks, commands, register map, rates,
  gains, frames, temperature sensor) and `Config`, a register map decoded.
- convert.py: conversion results of a running chip, vectorised over a capture.
- chip.py: one chip byte by byte on its SPI bus (`ADS1292`), strict about
  timing and fixed bits, codes from convert.py.
- bus.py: several chips on one bus with a shared START (`SPIBus`).
"""
