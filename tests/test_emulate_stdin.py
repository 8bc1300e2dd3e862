"""`fluxcal emulate` reads single keys from standard input in a thread of its own; whatever becomes
of that input (never opened, ending, a terminal that hangs up) the emulator runs to its end and
exits 0 without a traceback (desktop/cli/emulate.py, _Keys). The in-process runtime: the key
reader is the same for every board."""

import os
import pty
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FLUXCAL = os.path.join(os.path.dirname(sys.executable), "fluxcal")
EMULATE = [FLUXCAL, "emulate", "--runtime", "cpython", "--seconds", "2"]


def quiet(rc, err):
    assert rc == 0 and "Traceback" not in err and "Exception in thread" not in err, (rc, err)


def test_emulate_started_with_standard_input_closed():
    # `fluxcal emulate <&-`: Python sees no standard input at all (sys.stdin is None)
    p = subprocess.run(EMULATE, stdin=subprocess.DEVNULL, capture_output=True, text=True, cwd=ROOT,
                       timeout=120, preexec_fn=lambda: os.close(0))
    quiet(p.returncode, p.stderr)
    assert "ready: the firmware runs" in p.stdout


def test_emulate_whose_piped_keys_end():
    # a program steers the operator ('p' presses the button) and closes the pipe: the operator
    # carries on as it was until --seconds
    p = subprocess.run(EMULATE, input="p", capture_output=True, text=True, cwd=ROOT, timeout=120)
    quiet(p.returncode, p.stderr)
    assert "ready: the firmware runs" in p.stdout


def test_emulate_whose_terminal_hangs_up(tmp_path):
    # the terminal closes under the key reader (its window shut): reads fail with EIO, the terminal's
    # mode cannot be restored; neither is an error of the emulator's
    err = tmp_path / "stderr"
    master, slave = pty.openpty()
    with open(err, "w") as errf:
        p = subprocess.Popen(EMULATE, stdin=slave, stdout=subprocess.PIPE, stderr=errf, text=True, cwd=ROOT)
        os.close(slave)
        for line in p.stdout:
            if line.startswith("ready:"):
                break
        time.sleep(0.3)        # the key reader is in its select on the terminal now
        os.close(master)
        out = p.stdout.read()
        rc = p.wait(timeout=120)
    quiet(rc, err.read_text())
    assert "Traceback" not in out
