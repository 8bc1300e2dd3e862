# The one list of firmware files, in MicroPython's manifest format.
#
# MicroPython's freezing tool runs it (bytecode in flash, see docs/firmware.md):
#   make -C ports/rp2 BOARD=RPI_PICO FROZEN_MANIFEST=$PWD/device/manifest.py
# desktop/firmware/files.py runs it too, with recording stand-ins for module()
# and package(), per runtime (options.runtime): that is where device/package.json
# (mpremote mip install), the .mpy images of the simulated boards and the
# CircuitPython file list come from. tests/test_firmware_files.py fails when a
# module the firmware imports is missing here or package.json has drifted.

options.defaults(runtime="micropython")   # or "circuitpython", "sim" (the desktop's HAL link)

metadata(description="fluxcal: ADS1292 fluxgate magnetometer with in-field calibration", version="0.1.0")
if options.runtime == "micropython":
    include("$(PORT_DIR)/boards/manifest.py")   # the port's own frozen modules stay

# Every runtime: the application, the ADS1292 driver and the HAL contract.
for name in ("acceptance", "acquisition", "ads1292", "app", "bootguard", "button", "calibration_flow", "commands",
             "config", "firmware_names", "flashlog", "gates", "hal", "health", "lagfit", "led", "protocol",
             "residual_stats", "residuals", "screen", "session", "session_modules", "store", "survey", "surveylog"):
    module(name + ".py", opt=3)

# The runtime's HAL.
if options.runtime == "micropython":
    module("hal_micropython.py", opt=3)
elif options.runtime == "circuitpython":
    module("hal_circuitpython.py", opt=3)
elif options.runtime == "sim":
    # the simulated board's files sit in device/sim/ (a reader sees at once what a real board
    # gets) and deploy flat like the rest
    for name in ("hal_sim", "sim_link", "sim_main", "sim_wire"):
        module(name + ".py", base_path="sim", opt=3)

# The calibration core the firmware runs (pure Python, the same files as on the desktop). Not
# shipped: warmup.py and moved.py (coefficients from one long warm-up, which the firmware does
# not fit). tests/test_firmware_files.py checks this list against what the firmware imports.
package("shared", files=["__init__.py", "calibration.py", "codes.py", "coverage.py", "delag.py", "errors.py",
                         "fit.py", "fixedpoint.py", "honest.py", "iteration.py", "linalg.py", "linalg_native.py", "moments.py", "predicted.py", "prior.py",
                         "quadric.py",
                         "quick.py", "response.py", "result.py", "solver.py", "start.py", "tausums.py", "tempco.py"],
        base_path="..", opt=3)

# Entry points: copied to the filesystem's root, never frozen (a user edits or replaces them);
# (source, name on the board) where they differ. MicroPython's boot.py keeps a watchdog the
# firmware started fed through a soft reset; CircuitPython's remounts CIRCUITPY for the firmware.
ROOT_FILES = {"micropython": ("main.py", ("boot_micropython.py", "boot.py")), "circuitpython": ("code.py", "boot.py"),
              "sim": ()}
