"""`fluxcal demo`: handheld.py runs the firmware on the simulated handheld (the default);
core.py fits a simulated hand rotation with the shared/ core beside the references."""
