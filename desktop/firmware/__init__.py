"""The firmware as files: the one list (device/manifest.py), the tools that handle it.

- files.py: which files go on a board of each runtime, and device/package.json.
- image.py: those files compiled to .mpy with mpy-cross, as a board holds them.
- interpreters.py: where the `micropython` and `mpy-cross` executables are.
- mpy.py: which .mpy files a board loads (its sys.implementation._mpy against mpy-cross).
- deploy.py: the files onto a board with mpremote, or into a CIRCUITPY drive, staged and
  swapped in by renames; on-board/ holds the scripts mpremote runs on the board for it.
"""
