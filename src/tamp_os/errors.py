"""The few error types TAMP-OS raises. Each message names the file or parameter,
the allowed range, the value received and what to do, so the CLI can print it as is."""


class TampError(Exception):
    """Base class: a problem the user can fix; the CLI prints it without a traceback."""


class InputError(TampError):
    """An input file that cannot be read or used."""


class ParameterError(TampError, ValueError):
    """A parameter outside its allowed range."""


class MissingDependencyError(TampError):
    """An optional tool or library that is not installed."""


class ExportError(TampError):
    """An output that cannot be written."""
