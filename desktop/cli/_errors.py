"""The CLI's user-facing failure. Not a command (COMMANDS does not list it)."""


class CommandError(Exception):
    """A user-facing failure: printed as one line `fluxcal: message`, exit code 1."""
