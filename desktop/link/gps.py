"""Positions from a GPS receiver on a second serial port, while `fluxcal survey` records.

    gps = GpsReader(port, baud)     # pynmea2 (pip install 'fluxcal[gps]'); LinkError if the port fails
    gps.start()                     # a thread reads NMEA sentences, keeps the GGA fixes
    gps.fixes()                     # [(laptop monotonic s, lat deg, lon deg, fix quality)]
    gps.stop()

NMEA 0183 is parsed by pynmea2 (checksums checked: a sentence that fails is skipped
and counted). Only GGA sentences are kept: they carry the fix quality (0 none,
1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float), which says how far to trust a position.
The fixes are stamped with the laptop's clock when they arrive; the survey command
puts them on the board's clock through the data events' arrival times.
"""

import threading
import time

from desktop.link import LinkError


class GpsReader:
    def __init__(self, port, baud=9600):
        import pynmea2      # the gps extra: a missing one is named in one line (desktop/cli EXTRAS)
        import serial

        self._nmea = pynmea2
        try:
            self._ser = serial.Serial(port, baud, timeout=0.2)
        except (serial.SerialException, OSError, ValueError) as exc:
            why = getattr(exc, "strerror", None) or exc
            raise LinkError("the GPS on %s cannot be opened (%s)" % (port, why)) from None
        self.port = port
        self.bad = 0            # sentences that did not parse (a checksum, a cut line)
        self.error = None
        self._fixes = []
        self._stop = threading.Event()
        self._thread = None

    def start(self):
        self._thread = threading.Thread(target=self._run, name="gps", daemon=True)
        self._thread.start()

    def _run(self):
        buf = b""
        while not self._stop.is_set():
            try:
                data = self._ser.read(256)
            except OSError as exc:
                self.error = "the GPS on %s stopped: %s" % (self.port, exc)
                return
            buf += data
            *lines, buf = buf.split(b"\n")
            now = time.monotonic()
            for line in lines:
                self._sentence(line.decode("ascii", "replace").strip(), now)

    def _sentence(self, text, now):
        if not text.startswith("$"):
            return
        try:
            msg = self._nmea.parse(text, check=True)
            if getattr(msg, "sentence_type", "") != "GGA":
                return
            quality = int(msg.gps_qual or 0)
            if quality <= 0:
                return          # no fix: nothing to place a reading by
            fix = (now, float(msg.latitude), float(msg.longitude), quality)
        except (self._nmea.ParseError, ValueError, TypeError, AttributeError):
            self.bad += 1       # a checksum, a cut or garbled line
            return
        self._fixes.append(fix)

    def fixes(self):
        return list(self._fixes)

    def stop(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        self._ser.close()
