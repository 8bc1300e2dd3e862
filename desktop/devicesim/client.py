"""A small protocol client over pyserial, stepping a simulated device while it waits.

    c = Client(serial.Serial(world.serial_port, timeout=1), dev)
    c.ask("status")          # -> the reply dict (ok true or false)
    c.events("cal")          # unsolicited events seen so far, by name

With a simulated device nothing runs between calls, so `ask` advances the
device by `dt` of simulated time after writing, then reads what it printed.
A pty hands bytes over asynchronously, and simulated time runs far faster than
wall time, so the client waits for its request to reach the World before the
device runs, and reads exactly the bytes the World put into the pty.
"""

import json


class Client:
    def __init__(self, ser, dev, dt=0.05):
        self.ser = ser
        self.dev = dev
        self.dt = dt
        self.seen = []     # every JSON line read, in order
        self.junk = []     # complete lines that were not JSON (must stay empty)
        self._partial = b""   # the start of a line whose end has not arrived yet
        # what crossed the pty before this client opened it is not its to read (pyserial
        # empties the input buffer on open); count from here
        ser.reset_input_buffer()
        self._got = dev.world.to_host     # bytes of the World's output accounted for
        self._sent = dev.world.from_host  # bytes of input the World has received

    def _drain(self):
        data = self._partial
        want = self.dev.world.to_host - self._got
        if want > 0:
            got = self.ser.read(want)   # blocks (up to the port's timeout) until they crossed
            self._got += len(got)
            data += got
        *lines, self._partial = data.split(b"\n")
        for line in lines:
            try:
                self.seen.append(json.loads(line))
            except ValueError:
                self.junk.append(line)

    def write(self, data):
        self.ser.write(data)
        self.ser.flush()
        self._sent += len(data)
        self.dev.world.receive(self._sent)

    def step(self, dt=None):
        w = self.dev.world
        self.dev.run_until(w.time + (self.dt if dt is None else dt))
        self._drain()

    def ask(self, line, dt=None):
        """Send one command line; return the first reply (a dict with "ok") after it."""
        start = len(self.seen)
        self.write(line.encode() + b"\n" if isinstance(line, str) else line)
        for _ in range(20):
            self.step(dt)
            for d in self.seen[start:]:
                if "ok" in d:
                    return d
        raise TimeoutError("no reply to %r" % (line,))

    def replies(self):
        return [d for d in self.seen if "ok" in d]

    def events(self, name=None):
        self._drain()
        return [d for d in self.seen if "ev" in d and (name is None or d["ev"] == name)]
