# Freeze the firmware into a MicroPython build:
#   make -C ports/rp2 BOARD=RPI_PICO FROZEN_MANIFEST=/path/to/fluxcal/device/manifest.py
metadata(description="fluxcal: ADS1292 fluxgate magnetometer with in-field calibration", version="0.1.0")
include("$(PORT_DIR)/boards/manifest.py")
for name in ("ads1292", "acquisition", "app", "button", "calibrate", "config", "hal_micropython",
             "led", "protocol", "store", "survey"):
    module(name + ".py", opt=3)
package("shared", base_path="..", opt=3)
