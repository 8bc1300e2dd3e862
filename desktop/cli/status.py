"""fluxcal status [--port P]: what the handheld is doing and which calibration is in force."""

import json

from desktop.cli._device import add_port_arguments, connected

HELP = "the handheld's firmware, calibration in force, acquisition health and faults"


def add_arguments(p):
    add_port_arguments(p)
    p.add_argument("--json", action="store_true", help="print the device's replies as one JSON object")


def run(args):
    from desktop.cli._show import SOURCES, calibration_lines
    from desktop.link.ports import emulator_on

    with connected(args) as dev:
        st = dev.ask("status")
        cal = dev.ask("get-cal")["cal"]
    if args.json:
        print(json.dumps({"port": dev.port, "version": dev.info, "status": st, "cal": cal}, indent=1))
        return 0
    v = dev.info
    emulator = emulator_on(dev.port)
    where = dev.port if emulator is None else "%s, a virtual handheld (fluxcal emulate, pid %d)" % (
        dev.port, emulator["pid"])
    print("fluxcal firmware %s on %s: protocol %s, runtime %s (%s)"
          % (v.get("fw"), where, v.get("proto"), v.get("runtime"), v.get("impl")))
    state = "%s, up %.1f s, stream %s" % (st.get("state"), st.get("uptime_ms", 0) / 1000.0, st.get("stream"))
    if st.get("temp") is not None:
        state += ", ADC die %.2f C" % st["temp"]
    print("state: " + state)
    if cal is None:
        print("calibration: none in force (fluxcal calibrate, or push one with fluxcal push-cal)")
    else:
        print("calibration: in force, %s" % SOURCES.get(st.get("cal_source"), st.get("cal_source")))
        for line in calibration_lines(cal, st):
            print("  " + line)
    if st.get("temp_warn"):
        print("  warning: the temperature differs from the calibration's by more than temp_warn_c")
    if st.get("cal_problem"):
        print("  stored calibration refused at boot: %s" % st["cal_problem"])
    if "frames" in st:
        print("acquisition: %d frames, %d samples; dropped: %d ring overflows, %d missed conversions, "
              "%d discarded blocks, %d bad status headers, %d gaps"
              % (st["frames"], st["samples"], st["overflow"], st["missed"], st["discarded"], st["badsync"],
                 st["gaps"]))
    paths = _paths(st)
    if paths:
        print("code paths: " + paths)
    faults = [st["fault"]] if st.get("fault") else []
    faults += ["config: %s" % p for p in st.get("config_problems") or []]
    if (st.get("log") or {}).get("error"):
        faults.append("log: %s" % st["log"]["error"])
    print("faults: " + ("; ".join(faults) if faults else "none"))
    if st.get("watchdog_reset"):
        print("reset by the watchdog: the firmware's main loop hung (%d unfinished boots in a row before this one)"
              % st.get("unfinished_boots", 0))
    if st.get("safe_mode"):
        print("safe mode, the stored calibration not applied: %s (set-cal or clear-cal ends it)" % st["safe_mode"])
    last = st.get("last_cal")
    if last:
        print(last_cal_line(last))
    if st.get("cal"):
        c = st["cal"]
        print("calibrating now: %d samples, coverage %.0f %%" % (c.get("n", 0), 100 * (c.get("coverage") or 0)))
    return 0


# status's keys that say which code runs, in a line's words (docs/protocol.md, Status)
PATHS = (("sums", "fit sums"), ("linalg", "solver's float work"), ("drdy", "DRDY handler"), ("reader", "ring reader"),
         ("sample", "sample path"), ("screen", "spike screen"), ("delag", "de-lag"), ("magnitude", "|h_c|"))


def _paths(st):
    """'in C: fit sums, ...; in Python: ...' from status's path keys (those it sends), or ''."""
    said = {}
    for key, words in PATHS:
        if st.get(key) in ("native", "python"):
            said.setdefault(st[key], []).append(words)
    return "; ".join("in %s: %s" % ("C" if path == "native" else "Python", ", ".join(said[path]))
                     for path in ("native", "python") if path in said)


SINCE = {"set-cal": "replaced since by a calibration sent with set-cal (fluxcal push-cal, calibrate)",
         "clear-cal": "cleared since (clear-cal)",
         "keep-cal": "put in force since (keep-cal, fluxcal calibrate --replace)"}


def last_cal_line(last):
    """status's last_cal in one line: the session's end, its reason and message, and whether its
    calibration is the one in force now (a set-cal, keep-cal or clear-cal since changes that)."""
    extra = " (%s)" % last["reason"] if last.get("reason") else ""
    line = "last calibration since boot: %s%s%s" % (last.get("state"), extra,
                                                    ": " + last["msg"] if last.get("msg") else "")
    if last.get("since"):
        line += "; %s: %s" % (SINCE.get(last["since"], last["since"]),
                              "in force" if last.get("in_force") else "not in force")
    elif last.get("in_force") is False:
        line += "; not in force (the handheld holds it until its next calibration or power-off)"
    return line
