"""The firmware's native modules (device/native/*.c) as .mpy files, one per module and architecture:
fitsums.c the fit's sums and the survey's |h_c|, drdy.c the DRDY handler, screenc.c the common
path of the spike screen's push (device/screen.py), delagc.c the de-lag's (shared/delag.py),
gatesc.c the calibration gates' sample (device/gates.py), linalgc.c the solver's float kernels
(shared/linalg.py).

    python -m desktop.firmware.natmod build        # build what is missing (cached in build/)
    natmod_path("armv6m")                          # build/interpreters/natmod/<sources>/armv6m/fitsums.mpy, or None
    natmod_path("armv6m", "drdy")                  # .../armv6m/drdy.mpy, or None
    natmod_for(decode_mpy(board_mpy), "drdy")      # the file a board loads, or None (pure Python there)

Built with MicroPython's native-module tooling (py/dynruntime.mk, tools/mpy_ld.py) from the
rp2 source tree in ../shared/rp2, the same v1.28.0 as the emulated Pico, so the files are
.mpy v6.3: what the pip `micropython`, the unix builds here and the Pico load. mpy_ld needs
pyelftools (the test extra), the Arm ones arm-none-eabi-gcc, x86 gcc -m32. CircuitPython
loads no MicroPython .mpy and keeps the pure-Python sums, handler, screen, de-lag, gates and linear
algebra.
"""

import concurrent.futures
import glob
import hashlib
import importlib.util
import os
import shutil
import subprocess
import sys
import tarfile

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.path.join(os.path.dirname(REPO), "shared")
BUILD = os.path.join(REPO, "build", "interpreters", "natmod")
SOURCE = os.path.join(REPO, "device", "native")
MODULE = "fitsums"                 # the fit's sums and the survey's |h_c|
# and the DRDY handler, the spike screen, the de-lag, the gates, the solver's linear algebra
# (device/native/<name>.c)
MODULES = (MODULE, "drdy", "screenc", "delagc", "gatesc", "linalgc")
# the architectures built: x64 the 64-bit unix ports, x86 the 32-bit one (micropython-reprc),
# armv6m the RP2040's Cortex-M0+, armv7m Cortex-M3 boards (qemu-m3)
ARCHS = ("x64", "x86", "armv6m", "armv7m")
VERSION = (6, 3)     # the .mpy version v1.28.0's tooling writes
TARBALL = "rp2/micropython-*-rp2-src.tar.xz"


def _stamp():
    """What a build depends on: the sources and the tooling's archive (None without the sources:
    an installed wheel, which has no build/ either)."""
    if not os.path.isdir(SOURCE):
        return None
    parts = [os.path.basename(p) for p in sorted(glob.glob(os.path.join(SHARED, TARBALL)))]
    for name in sorted(os.listdir(SOURCE)):
        with open(os.path.join(SOURCE, name), "rb") as fh:
            parts.append(name + ":" + fh.read().hex())
    return "\n".join(parts)


def _out(arch):
    """build/interpreters/natmod/SOURCES/ARCH: a folder per version of the sources, so checkouts
    sharing build/ (worktrees) keep each their own."""
    stamp = _stamp()
    digest = hashlib.sha256(stamp.encode()).hexdigest()[:12] if stamp else "none"
    return os.path.join(BUILD, digest, str(arch))


def _stamp_ok(arch):
    stamp = _stamp()
    try:
        with open(os.path.join(_out(arch), "recipe")) as fh:
            return stamp is not None and fh.read() == stamp
    except OSError:
        return False


def natmod_path(arch, module=MODULE):
    """The built <module>.mpy for `arch` (an mpy-cross -march name), or None."""
    path = os.path.join(_out(arch), module + ".mpy")
    return path if arch in ARCHS and module in MODULES and os.path.exists(path) and _stamp_ok(arch) else None


def natmod_for(target, module=MODULE):
    """The <module>.mpy a board loads (target: desktop.firmware.mpy.decode_mpy of its _mpy), or None
    when none matches its architecture and .mpy version: the board then runs the pure Python."""
    if target is None or (target.version, target.sub) != VERSION:
        return None
    return natmod_path(target.arch, module)


def _tooling():
    """The MicroPython tree with py/dynruntime.mk (the rp2 build's extracted source), or None."""
    trees = glob.glob(os.path.join(REPO, "build", "interpreters", "src", "micropython-*-rp2"))
    if trees:
        return trees[0]
    tree = os.path.join(BUILD, "src")
    if os.path.isdir(tree):     # extracted by an earlier build here
        return tree
    tarballs = glob.glob(os.path.join(SHARED, TARBALL))
    if not tarballs:
        return None
    part = os.path.join(BUILD, "src.part")
    os.makedirs(part, exist_ok=True)
    with tarfile.open(tarballs[0]) as tar:
        tar.extractall(part)
    os.rename(os.path.join(part, os.listdir(part)[0]), tree)
    shutil.rmtree(part, ignore_errors=True)
    return tree


def _missing(arch):
    if importlib.util.find_spec("elftools") is None:     # tools/mpy_ld.py reads the object files with it
        return "pyelftools (pip install pyelftools)"
    if arch.startswith("arm") and shutil.which("arm-none-eabi-gcc") is None:
        return "arm-none-eabi-gcc"
    if arch == "x86":
        r = subprocess.run(["gcc", "-m32", "-x", "c", "-o", os.devnull, "-"], input="int main(){return 0;}",
                           capture_output=True, text=True)
        if r.returncode:
            return "gcc -m32 (Debian's gcc-multilib)"
    return None


def _built(arch):
    """Every module's .mpy for `arch`, or None."""
    paths = [natmod_path(arch, m) for m in MODULES]
    return None if None in paths else paths


def build(arch, log=print):
    """Build every module's .mpy for one architecture unless they are there; returns their paths or None."""
    label = "natmod " + arch
    if _built(arch):
        log("%-20s cached  %s" % (label, " ".join(os.path.relpath(p, REPO) for p in _built(arch))))
        return _built(arch)
    missing = _missing(arch) if os.path.isdir(SOURCE) else "the sources (%s)" % SOURCE
    tree = None if missing else _tooling()
    if missing or tree is None:
        log("%-20s missing: %s" % (label, "this machine lacks " + missing if missing else
                                   "no %s (../shared beside the repository)" % os.path.join(SHARED, TARBALL)))
        return None
    out = _out(arch)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    for name in os.listdir(SOURCE):
        shutil.copy2(os.path.join(SOURCE, name), out)
    # mpy_ld runs as `python3`: this interpreter's folder first, where pip put pyelftools. Its layout
    # of linalgc's runtime (libgcc's members) follows Python's string hashing: a fixed seed makes
    # each build the same bytes (two builds of linalgc.mpy differed in a few bytes without it)
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""),
               PYTHONHASHSEED="0")
    with open(os.path.join(out, "build.log"), "w") as logfile:
        for module in MODULES:
            r = subprocess.run(["make", "-C", out, "MPY_DIR=" + tree, "ARCH=" + arch, "MOD=" + module],
                               stdout=logfile, stderr=subprocess.STDOUT, env=env)
            if r.returncode:
                log("%-20s failed: make exited %d for %s (see %s)" % (label, r.returncode, module,
                                                                     os.path.relpath(logfile.name, REPO)))
                return None
    with open(os.path.join(out, "recipe"), "w") as fh:
        fh.write(_stamp())
    log("%-20s built   %s" % (label, " ".join(os.path.relpath(p, REPO) for p in _built(arch))))
    return _built(arch)


def main(argv=None):
    args = sys.argv[1:] if argv is None else argv
    if args[:1] == ["build"]:
        _tooling()      # the tree, once, before two architectures build from it at a time: within one,
        # its modules' makes share a folder and run in turn (the compiles and mpy_ld's link are serial)
        with concurrent.futures.ThreadPoolExecutor(2) as lanes:
            list(lanes.map(build, args[1:] or ARCHS))
        return 0
    print("usage: python -m desktop.firmware.natmod build [ARCH...]", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
