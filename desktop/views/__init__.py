"""The pictures fluxcal shows of a calibration, for the terminal and for PNG files.

    from desktop.views.sphere import SphereMap, largest_gap, describe
    m = SphereMap(cells_per_edge=4)            # an equal-area grid of the sphere over the firmware's cells
    gap = largest_gap(counts, 4)               # the largest connected set of empty cells
    describe(gap)                              # "around -Z, towards +X (40 % of the sphere)"

    from desktop.views.coverage_text import map_lines, guidance
    print("\n".join(map_lines(counts, 4, cap, now=(dx, dy, dz))))   # glyphs, axis labels, legend

    from desktop.views.figures import coverage_figure, error_figure, rate_figure   # matplotlib

Directions are those of the field in the sensor's own axes, as the firmware's
coverage cells count them (shared/coverage.py): a cell at +Z fills while the
sensor's +Z axis points along the Earth's field.
"""
