# Runs under each interpreter (the micropython builds, CircuitPython, CPython, and the
# bare-metal Cortex-M3 board, which has no sys.argv: it imports this file and calls
# main()): reads a JSON job {"points": [[x, y, z], ...], "field": F or null, "scale": s,
# "prior": a previous calibration (quick re-calibration) or absent}
# from the file named in argv[1], fits it with shared.fit (the repository root is
# argv[2]) and prints one JSON line: the exact power sums, the calibration, and the
# solver's fixed-point integer state at convergence (read by wrapping
# shared.solver.finish, which receives it).
import json
import sys


def main(job_path, root):
    if root not in sys.path:
        sys.path.insert(0, root)
    from shared import solver
    from shared.calibration import Calibration
    from shared.fit import EllipsoidFit, FitError

    states = []
    _finish = solver.finish

    def _spy(pb, pr, st, *args):
        states.append([[str(x) for x in st.a_int], [str(x) for x in st.f_int]])
        return _finish(pb, pr, st, *args)

    with open(job_path) as fh:
        job = json.load(fh)
    fit = EllipsoidFit()
    for p in job["points"]:
        fit.add(p[0], p[1], p[2])
    field, scale = job["field"], job["scale"]
    prior = Calibration.from_dict(job["prior"]) if job.get("prior") else None
    job = None   # the points' lists: free before the solve (a board's heap is small)
    out = {"sums": [str(s) for s in fit.sums()]}
    solver.finish = _spy
    try:
        cal = fit.solve(field=field, scale=scale, prior=prior)
        out["calibration"] = cal.to_dict()
        out["state"] = states[0]   # a quick re-calibration solves twice: its own state first
    except FitError as exc:
        out["reason"] = exc.reason
    finally:
        solver.finish = _finish
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
