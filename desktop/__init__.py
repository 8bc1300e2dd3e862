"""fluxcal desktop side (CPython + numpy): references, simulator, CLI, serial link."""
