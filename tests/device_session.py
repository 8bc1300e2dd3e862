"""A firmware on the simulated handheld, driven line by line without a pty (the fault matrix's tests).

    w, dev = boot(tmp_path, "micropython", seconds=30.0, motion="stationary", fault=(None, None))
    w, dev = configured(tmp_path, "hand", 45.0, auto_finish=False)   # in-process, the handheld's config
    reply = ask(w, dev, "status")            # the reply dict; ask_all: (reply, every JSON line)
    events(w, "fault", since)                # events by name from line index `since`
"""

import contextlib
import json

import serial

from desktop.devicesim.runners import start_device
from desktop.devicesim.world import make_world
from tests.interpreters import need


def boot(tmp_path, kind="cpython", seconds=30.0, seed=11, motion="stationary", **scenario):
    if kind not in ("micropython", "cpython"):
        need(kind)
    w = make_world(serial=None, motion=motion, seconds=seconds, seed=seed, **scenario)
    dev = start_device(w, str(tmp_path), kind=kind)
    dev.run_until(0.3)
    return w, dev


def configured(tmp_path, motion, seconds, **cfg):
    """The firmware in this process on a 2000 SPS handheld, its config the scenario's
    (handheld_config) with `cfg` over it; booted for 0.5 s."""
    from desktop.devicesim.procedure import handheld_config
    from desktop.devicesim.runners import write_config

    w = make_world(serial=None, motion=motion, seconds=seconds, seed=4, motion_seed=5, rate=2000)
    write_config(str(tmp_path), **handheld_config(w.scenario), **cfg)
    dev = start_device(w, str(tmp_path), kind="cpython")
    dev.run_until(0.5)
    return w, dev


def ask_all(w, dev, line, dt=0.3):
    """Send one line; (the last reply, every JSON line printed since)."""
    start = len(w.lines())
    w.send(line.encode() + b"\n")
    dev.run_until(w.time + dt)
    out = [json.loads(x) for x in w.lines()[start:]]
    replies = [d for d in out if "ok" in d]
    assert replies, "no reply to %r: %r" % (line[:60], out)
    return replies[-1], out


def ask(w, dev, line, dt=0.3):
    return ask_all(w, dev, line, dt)[0]


def events(w, name, since=0):
    return [json.loads(x) for x in w.lines()[since:] if '"ev": "%s"' % name in x]


def data_after(w, dev, seconds=1.0):
    """The data events of the next `seconds`."""
    start = len(w.lines())
    dev.run_until(w.time + seconds)
    return events(w, "data", start)


@contextlib.contextmanager
def on_pty(tmp_path, seconds=30.0, timeout=2):
    """A still handheld whose firmware (in-process) answers on a real pseudo-terminal:
    (world, device, pyserial port opened exclusively as a host would)."""
    w = make_world(serial="pty", motion="stationary", seconds=seconds, seed=5)
    dev = start_device(w, str(tmp_path), kind="cpython")
    dev.run_until(0.5)
    ser = serial.Serial(w.serial_port, baudrate=115200, timeout=timeout, exclusive=True)
    try:
        yield w, dev, ser
    finally:
        ser.close()
        dev.close()
