# MicroPython script, run by desktop/bench/heap.py as `micropython -X heapsize=... -m firmware_heap`
# from a folder holding it, loopboard.py, the .mpy image in lib/ and the frame file (data for that
# benchmark, not a module of the desktop package): the heap a board would show while the firmware runs.
# argv: frames_file root rate decim window seconds scale (nT/code) [track (0/1)]
# Boots App on a LoopBoard (loopboard.py) that reads real frames of a hand
# rotation from the open file, so the frame table never sits in the heap. Figures are gc.mem_alloc()
# after gc.collect(), the whole heap (interpreter start-up, this script and loopboard included; "harness"
# is that part, taken before the firmware's import): after boot; calibrating, after `seconds` of data
# through the real main loop (App.step + App.wait), just before the button's finish_session; survey,
# after `seconds` more with stream "corrected" and logging on. track=1 also collects after every
# loop pass and keeps the largest figure per phase (peaks between passes; the solve inside
# finish_session is not seen). A MemoryError ends the run with {"failed": phase}; so does a
# calibration the firmware could not save (it catches that MemoryError itself).
# The figures live in a list of small ints allocated before the baseline: nothing measured is the harness's.
import gc
import sys

from loopboard import LoopBoard, finish_cal, parts, start_cal

KEYS = ("harness", "boot", "cal", "cal_peak", "survey", "survey_peak", "state", "saved", "log_lines")
M = [0] * len(KEYS)
PEAK = [0]


def heap():
    gc.collect()
    return gc.mem_alloc()


def probe(app):
    a = heap()
    if a > PEAK[0]:
        PEAK[0] = a


def main():
    frames, root = sys.argv[1], sys.argv[2]
    rate, decim, window, seconds = (int(a) for a in sys.argv[3:7])
    each = probe if len(sys.argv) > 8 and sys.argv[8] == "1" else None
    src = open(frames, "rb")
    M[0] = heap()
    phase = "import"
    try:
        import app as appmod
        import store
        phase = "boot"
        scale = float(sys.argv[7])
        store.save(root, "config", {"rate": rate, "decim": decim, "window": window, "scale_x": scale,
                                    "scale_y": scale, "scale_z": scale, "auto_finish": False})
        scale = None
        board = LoopBoard(src, root, rate)
        app = appmod.App(board)
        M[1] = heap()
        phase = "calibrate"
        start_cal(app)
        PEAK[0] = 0
        board.run(app, seconds * rate, each)
        M[2] = heap()
        M[3] = PEAK[0]
        phase = "finish"
        r = finish_cal(app)
        M[6] = r["state"]   # a name the firmware's bytecode holds: no allocation
        M[7] = r.get("saved") is True
        r = None
        phase = "survey"
        app.cfg["log"] = True
        output = parts(app)[1]
        output.stream = "corrected"
        app._setup_pipeline()
        PEAK[0] = 0
        board.run(app, seconds * rate, each)
        M[4] = heap()
        M[5] = PEAK[0]
        M[8] = output.log.lines if output.log.error is None else -1
        phase = None
    except MemoryError:
        app = board = r = None
    except Exception as e:   # the firmware's refusal for want of memory (a start: calibration_flow.py)
        if getattr(e, "code", None) != "no_memory":
            raise
        app = board = r = None
    gc.collect()
    import json
    out = dict(zip(KEYS, M))
    if phase is None and not (M[6] == "done" and M[7] and M[8] > 0):
        phase = "state " + M[6] if M[6] != "done" else "not saved" if not M[7] else "no log"
    if phase is not None:
        out["failed"] = phase
    out["heap_total"] = gc.mem_alloc() + gc.mem_free()
    print(json.dumps(out))


main()
