"""Which .mpy files a board loads: its `sys.implementation._mpy` against mpy-cross's output.

    board = decode_mpy(2822)            # MpyTarget(version=6, sub=3, arch="x64")
    cross = cross_version(exe)          # (6, 3): what `mpy-cross --version` emits
    mpy_mismatch(board, cross)          # None, or why the board refuses those files

A board's `_mpy` packs the .mpy version it loads in the low byte, the sub-version in
bits 8-9 and its native-code architecture in bits 10 and up (py/persistentcode.h in
MicroPython's source). A .mpy of bytecode alone loads wherever the version matches;
native code (@native, @viper) needs the sub-version and the architecture too, which
is why deploy passes the board's arch to mpy-cross as `-march`.
"""

import collections
import re
import subprocess

# MP_NATIVE_ARCH_* in the order of py/persistentcode.h, named as mpy-cross's -march takes them
ARCHS = (None, "x86", "x64", "armv6", "armv6m", "armv7m", "armv7em", "armv7emsp", "armv7emdp", "xtensa",
         "xtensawin", "rv32imc", "rv64imc")

MpyTarget = collections.namedtuple("MpyTarget", "version sub arch")


def decode_mpy(mpy):
    """The board's _mpy as (version, sub-version, -march name or None); None when it has no _mpy."""
    if not mpy:
        return None
    arch = mpy >> 10
    return MpyTarget(mpy & 0xFF, (mpy >> 8) & 3, ARCHS[arch] if arch < len(ARCHS) else None)


def cross_version(exe):
    """(version, sub-version) of the .mpy files mpy-cross `exe` writes ("... emitting mpy v6.3")."""
    try:
        r = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=30)
    except OSError as exc:
        raise RuntimeError("cannot run mpy-cross %s: %s" % (exe, exc.strerror)) from None
    m = re.search(r"emitting mpy v(\d+)(?:\.(\d+))?", r.stdout + r.stderr)
    if m is None:
        raise RuntimeError("%s --version does not say which .mpy version it emits: %r" % (exe, r.stdout.strip()))
    return int(m.group(1)), int(m.group(2) or 0)


def mpy_mismatch(board, cross, native=False):
    """Why a board (decode_mpy) cannot load what mpy-cross (cross_version) writes, or None.

    native: the files hold native code, which must also match sub-version and arch."""
    if board is None:
        return "the board loads no .mpy files (its sys.implementation has no _mpy)"
    if board.version != cross[0]:
        return "the board loads .mpy version %d, mpy-cross writes version %d" % (board.version, cross[0])
    if native and board.sub != cross[1]:
        return "the board loads native code of .mpy v%d.%d, mpy-cross writes v%d.%d" % (
            board.version, board.sub, cross[0], cross[1])
    if native and board.arch is None:
        return "the board's native architecture is unknown to mpy-cross"
    return None
