"""fluxcal capture --seconds S -o FILE.npz: record the handheld's raw samples for offline fitting.

The firmware's `raw` stream gives block means of its decimated samples at
survey_hz. For the duration of the capture survey_hz is set to the sample rate
(rate / decim, 100 Hz by default), so every sample the calibration gates would
see is recorded as it is (a 0.1 s mean of vectors would shrink |B| while the
sensor turns, docs/simulator.md), then set back. The file is a recording in
desktop/formats/capture.py's format: `fluxcal fit FILE.npz -o CAL.json` fits it.
Its time column is the samples' times (sample_times), from their numbers, not the events'
times: the firmware sends what the main loop drains in one pass in the same millisecond (two
samples every 20 ms at 100 Hz), and a de-lag (`fit --lag`, or `report` with a calibration
that carries a response) differentiates over these times.
It asks the operator to turn the sensor while it records, and says afterwards
how much of the sphere the recording covers (the firmware's cells about zero,
as a calibration without a previous one counts them), with a warning and the
largest gap named when that is less than a calibration wants.
"""

import sys
import time

from desktop.cli._errors import CommandError
from desktop.cli._device import (add_port_arguments, connected, device_config, nT_per_code, quietly,
                                 stream_events)
from shared import codes

WRAP = 1 << 30     # the firmware's block numbers wrap (device/acquisition.py)
HELP = "record the handheld's raw samples (codes, temperature) to a capture file fluxcal fit reads"


def add_arguments(p):
    p.add_argument("--seconds", type=float, required=True, metavar="S", help="how long to record")
    p.add_argument("-o", "--output", required=True, metavar="FILE.npz", help="capture file to write")
    p.add_argument("--hz", type=int, default=None,
                   help="samples per second (default: the device's decimated rate, at most 100)")
    add_port_arguments(p)


def run(args):
    from desktop.formats.capture import save_recording

    if not 0 < args.seconds <= 24 * 3600:
        raise CommandError("--seconds must be in (0, 86400]")
    with connected(args) as dev:
        cfg = device_config(dev)
        hz = args.hz or max(1, min(100, round(cfg["rate"] / cfg["decim"])))
        print("recording %g s: turn the handheld slowly about every axis while it records" % args.seconds,
              flush=True)
        stream_before = dev.ask("status")["stream"]
        if hz != cfg["survey_hz"]:
            dev.ask("config set survey_hz %d" % hz)
        try:
            dev.ask("stream raw")
            events = _record(dev, args.seconds, hz)
        finally:
            quietly(dev, "stream %s" % stream_before)
            if hz != cfg["survey_hz"]:
                quietly(dev, "config set survey_hz %d" % cfg["survey_hz"])
    if len(events) < 2:
        raise CommandError("only %d samples in %g s: nothing written" % (len(events), args.seconds))
    t = sample_times(events, cfg["decim"] / float(cfg["rate"]), 1.0 / hz)
    meta = {"source": "fluxcal capture", "port": dev.port, "version": dev.info, "survey_hz": hz,
            "device_config": cfg}
    save_recording(args.output, [e["c"] for e in events], t, nT_per_code(cfg), [e["temp"] for e in events], meta)
    temps = [e["temp"] for e in events]
    print("wrote %s: %d samples over %.1f s at %d Hz, die %.2f..%.2f C; fit it with "
          "`fluxcal fit %s -o CAL.json`" % (args.output, len(events), t[-1], hz, min(temps), max(temps), args.output))
    _say_coverage([e["c"] for e in events], nT_per_code(cfg), cfg)
    return 0


def sample_times(events, sample_s, period_s):
    """The samples' times (s from the first) of raw events: their numbers `n` (the firmware's
    decimated samples, sample_s apart, wrapping at 2**30) count the samples lost between two
    (a ring overflow, a spike the screen dropped); a firmware that sends no `n`: period_s apart."""
    if not all(e.get("n", -1) >= 0 for e in events):
        return [i * period_s for i in range(len(events))]
    out = [0.0]
    for a, b in zip(events, events[1:]):
        out.append(out[-1] + ((b["n"] - a["n"]) % WRAP) * sample_s)
    return out


def _say_coverage(codes_xyz, scale, cfg):
    from desktop.views.verdict import coverage_counts, coverage_warning

    h = [[c * k for c, k in zip(row, scale)] for row in codes_xyz]
    counts = coverage_counts(h, cfg["cells"])
    print("the recording covers %.0f %% of the sphere's %d cells"
          % (100.0 * sum(1 for c in counts if c) / len(counts), len(counts)))
    warning = coverage_warning(counts, cfg["cells"], cfg["min_coverage"])
    if warning:
        print(warning)


def _record(dev, seconds, hz):
    """The raw events for `seconds`, with a progress bar on a terminal."""
    silence = max(3.0, 5.0 / hz)
    if not sys.stdout.isatty():
        return list(stream_events(dev, codes.EV_RAW, seconds, silence))
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    events = []
    start = time.monotonic()
    with Progress(TextColumn("capturing"), BarColumn(), TextColumn("{task.fields[n]} samples"),
                  TimeRemainingColumn(), transient=True) as bar:
        task = bar.add_task("capture", total=seconds, n=0)
        for ev in stream_events(dev, codes.EV_RAW, seconds, silence):
            events.append(ev)
            bar.update(task, completed=time.monotonic() - start, n=len(events))
    return events
