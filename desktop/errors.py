"""The one domain exception of the command line."""


class CommandError(Exception):
    """A user-facing failure: printed as one line `fluxcal: message`, exit code 1."""
