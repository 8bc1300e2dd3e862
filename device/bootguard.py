"""A crash loop cannot brick the instrument: boots that never reach a healthy main loop are counted.

    starts, crash = bootguard.begin(root)   # at boot, before the calibration is loaded
    bootguard.healthy(root)                 # the main loop ran HEALTHY_MS without an escaping error
    bootguard.crashed(root, "TypeError: ...")   # app.start: an exception escaped the app

boot.txt holds the boots since the last healthy one and the last crash's text.
The app comes up in safe mode (the stored calibration not applied, the protocol
alive, the reason in `status`) when the previous boot recorded a crash or when
SAFE_AFTER boots in a row never became healthy (a hard fault or a watchdog reset
leaves no text): so `clear-cal`, `set-cal` or a redeploy can always reach it.
A quick power-off within HEALTHY_MS counts as an unfinished boot too; two in a row
are needed before that alone means safe mode.
On a filesystem the firmware cannot write (CircuitPython with the USB drive
writable by the host, boot.py) the guard cannot count and stays out of the way.
"""

import os

from store import file_path

NAME = "boot.txt"
SAFE_AFTER = 2         # unfinished boots before this one
HEALTHY_MS = 5000      # main loop time without an escaping error that counts as a good boot
_TEXT_MAX = 200


def _read(root):
    try:
        with open(file_path(root, NAME)) as f:
            text = f.read(400)
    except OSError:
        return 0, None
    lines = text.split("\n")
    try:
        starts = int(lines[0])
    except ValueError:
        return 0, None   # a torn write: no evidence of a crash loop
    crash = lines[1] if len(lines) > 1 and lines[1] else None
    return starts, crash


def _write(root, starts, crash):
    try:
        with open(file_path(root, NAME), "w") as f:
            f.write("%d\n%s\n" % (starts, (crash or "")[:_TEXT_MAX].replace("\n", " ")))
        return True
    except OSError:
        return False


def begin(root):
    """(unfinished boots before this one, the last crash's text or None); counts this boot."""
    starts, crash = _read(root)
    _write(root, starts + 1, crash)
    return starts, crash


def safe_reason(starts, crash):
    """Why this boot must not apply the stored calibration, or None."""
    if crash:
        return "the last boot crashed: %s" % crash
    if starts >= SAFE_AFTER:
        return "%d boots in a row stopped within %d s (crash, watchdog or power)" % (starts, HEALTHY_MS // 1000)
    return None


def healthy(root):
    try:
        os.remove(file_path(root, NAME))
    except OSError:
        pass


def crashed(root, text):
    starts, _ = _read(root)
    _write(root, starts, text)
