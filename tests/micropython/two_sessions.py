# Runs under a MicroPython build (tests/test_device_heap.py), from a folder holding loopboard.py
# (desktop/bench/micropython-scripts) and the frame file, the firmware's .mpy image on MICROPYPATH.
# argv: frames root scale resident(0/1). Boots the App on the loop-back board and runs two full
# calibrations one after the other, each on the same frames from the file's start (the board
# rewound, the ring drained, the spike screen reset, the calibration in force cleared).
# resident=1 imports the session's modules before the App boots, so they stay
# (calibration_flow.py drops only what a session brought). Prints one JSON line: each
# calibration's record (less its uptime), whether the session's modules were still imported
# after each finish, and the heap after each finish.
import gc
import json
import sys

from loopboard import LoopBoard, finish_cal, parts, start_cal

SESSION = ("session", "gates", "acceptance", "shared.fit", "shared.solver")
SECONDS = 15


def main():
    frames, root, scale, resident = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4] == "1"
    if resident:
        import session  # noqa: F401
    import app as appmod
    import store
    store.save(root, "config", {"rate": 1000, "decim": 10, "window": 2, "scale_x": scale, "scale_y": scale,
                                "scale_z": scale, "auto_finish": False})
    board = LoopBoard(open(frames, "rb"), root, 1000)
    app = appmod.App(board)
    flow, output = parts(app)
    out = {"cals": [], "loaded": [], "heap": []}
    for _ in range(2):
        app.step()                # the ring drained into the survey
        board.k = 0               # the same frames again, from a block's start
        output.screen.reset()
        if flow.cal is not None:
            flow.clear()          # none in force: an equal calibration would not replace it
        flow.start("full")
        board.run(app, SECONDS * 1000)
        r = finish_cal(app)
        cal = flow.cal.to_dict() if r["state"] == "done" else r
        cal.get("meta", {}).pop("uptime_ms", None)
        out["cals"].append(cal)
        out["loaded"].append([m for m in SESSION if m in sys.modules])
        gc.collect()
        out["heap"].append(gc.mem_alloc())
    print(json.dumps(out))


main()
