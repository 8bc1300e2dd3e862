"""The long survey run judged and printed: the invariants its figures must hold (`problems`)
and the markdown table of docs/long-run.md (`table`). The figures come from
desktop/bench/longrun.py's `run`.
"""

HEAP_TOLERANCE = 16384


def problems(f, heap_tolerance=HEAP_TOLERANCE):
    """The invariants that failed, as lines (empty: all held).

    The heap: MicroPython collects when an allocation finds no room, so mem_free is a
    sawtooth (here ~11 KB/s down from ~110 KB to ~1 KB, a collection every ~10 s). Its
    floor says nothing; its ceiling (free right after a collection: the heap minus what
    stays alive) is what a leak lowers. A window's max is the ceiling less the allocation
    since the collection before its best sample: the last window's max must not fall more
    than `heap_tolerance` below the first's (a leak of 0.6 B/s over 8 hours, of ~100 B/s
    over the CI run's minutes, exceeds it)."""
    out = []
    if f["state"] != "survey" or f["fault"]:
        out.append("state %r, fault %r" % (f["state"], f["fault"]))
    if not f["heap_first"] or not f["heap_last"]:
        out.append("no heap figures after warm-up (mem_free missing from status?)")
    elif f["heap_last"][1] < f["heap_first"][1] - heap_tolerance:
        out.append("heap ceiling fell from %d to %d bytes" % (f["heap_first"][1], f["heap_last"][1]))
    for key in ("missed", "overflow", "badsync", "discarded", "gaps", "merged_edges", "frames_vs_edges",
                "edges_vs_conversions", "bad_data"):
        if f[key]:
            out.append("%s = %d" % (key, f[key]))
    if f["frame_jumps"] < 1:
        out.append("fewer than two status replies with a host snapshot")
    lo, hi = f["unaccounted"]
    if lo < 0 or hi > 2:
        out.append("frames not accounted for: frames // decim - blocks in %d..%d" % (lo, hi))
    want = f["expected_per_minute"]
    if not f["per_minute"] or f["per_minute"][0] < want - 1 or f["per_minute"][1] > want + 1:
        out.append("data events per minute %s, expected %d +- 1" % (f["per_minute"], want))
    if f["log_files_max"] > f["log_files_allowed"] or f["log_bytes_max"] > f["log_bytes_allowed"]:
        out.append("logs: %d files, %d bytes (allowed %d, %d)" % (f["log_files_max"], f["log_bytes_max"],
                                                                 f["log_files_allowed"], f["log_bytes_allowed"]))
    if f["log_error"]:
        out.append("log error: %s" % f["log_error"])
    return out


def table(f):
    """The figures as a markdown table."""
    def mm(pair):
        return "n/a" if pair is None else "%d / %d" % pair
    hours = f["simulated_s"] / 3600.0
    win = "hour" if f["heap_window_s"] >= 3600 else "%.0f s" % f["heap_window_s"]
    rows = [
        ("simulated survey", "%.2f h (%d s), status every %d s: %d replies" % (hours, f["simulated_s"], f["every_s"],
                                                                           f["statuses"]), ""),
        ("config", "default" if not f["settings"] else "default but " + ", ".join(
            "%s %s" % kv for kv in sorted(f["settings"].items())), ""),
        ("wall time (the survey; with start-up)", "%.0f s (%.0f s), %.1fx real time"
         % (f["survey_wall_s"], f["wall_s"], f["speed"]), ""),
        ("CPU: harness (World, link, emulator, client) / firmware process", "%.0f s / %s"
         % (f["host_cpu_s"], "n/a" if f["firmware_cpu_s"] is None else "%.0f s" % f["firmware_cpu_s"]), ""),
        ("heap mem_free min / max, first %s after %d s warm-up" % (win, f["warm_up_s"]), mm(f["heap_first"]),
         "flat: last max >= first max - %d KB (a sawtooth: see problems())" % (HEAP_TOLERANCE // 1024)),
        ("heap mem_free min / max, last %s" % win, mm(f["heap_last"]), ""),
        ("heap mem_free max hour by hour, KB", ", ".join("%.1f" % (m / 1024) for m in f["heap_hourly_max"]) or "n/a",
         "no downward trend"),
        ("frames (DRDY edges counted by the firmware)", "%d" % f["frames"], ""),
        ("frame counter vs edges the World delivered, between replies", "%d of %d intervals differ"
         % (f["frames_vs_edges"], f["frame_jumps"]), "0"),
        ("edges vs chip 0's conversions, between replies; edges merged", "%d differ; %d merged"
         % (f["edges_vs_conversions"], f["merged_edges"]), "0; 0"),
        ("missed / overflow / badsync / discarded / gaps", "%d / %d / %d / %d / %d"
         % (f["missed"], f["overflow"], f["badsync"], f["discarded"], f["gaps"]), "0 each"),
        ("frames // decim - (samples + overflow + discarded), min / max", mm(f["unaccounted"]),
         "0..2 (the open block, the ring)"),
        ("data events per simulated minute, min / max (%d minutes)" % f["minutes"], mm(f["per_minute"]),
         "%d +- 1" % f["expected_per_minute"]),
        ("data events, not calibrated or > 50 nT off the field", "%d of %d" % (f["bad_data"], f["data_events"]), "0"),
        ("log files on the flash, most at a status", "%d" % f["log_files_max"], "<= %d" % f["log_files_allowed"]),
        ("log bytes on the flash, most at a status", "%d" % f["log_bytes_max"],
         "<= %d (log_files x log_file_bytes)" % f["log_bytes_allowed"]),
        ("log lines written; log error", "%s; %s" % (f["log_lines"], f["log_error"]), "none"),
        ("events besides data", ", ".join(f["events"]) or "none", ""),
    ]
    out = ["| what | measured | expected |", "|---|---|---|"]
    out += ["| %s | %s | %s |" % r for r in rows]
    return "\n".join(out)
