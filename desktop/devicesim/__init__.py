"""Run the device firmware (device/) against the emulated ADS1292, in CPython or in `micropython`."""
