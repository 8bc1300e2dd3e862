"""A walked survey's grid from the command line: --grid WxL and --line-spacing S, as `simulate
--motion survey`, `survey` and `emulate --survey` take them. Not a command (COMMANDS does not list it)."""

from desktop.cli._errors import CommandError


def parse_grid(text, spacing, option="--grid"):
    """(width_m, length_m) of 'WIDTHxLENGTH' (m); CommandError for a bad grid or line spacing."""
    try:
        width, length = (float(v) for v in text.lower().split("x"))
    except ValueError:
        raise CommandError("%s must be WIDTHxLENGTH in metres, e.g. 20x20, got %r" % (option, text))
    if not (1 <= width <= 200 and 1 <= length <= 200):
        raise CommandError("%s sides must be within 1..200 m" % option)
    if spacing is None or not 0.1 <= spacing <= width:
        raise CommandError("--line-spacing must be within 0.1 m and the grid's width")
    return width, length
