"""The firmware as files: the one list (device/manifest.py), the tools that handle it.

- files.py: which files go on a board of each runtime, and device/package.json.
- image.py: those files compiled to .mpy with mpy-cross, as a board holds them.
- interpreters.py: where the `micropython` and `mpy-cross` executables are.
"""
