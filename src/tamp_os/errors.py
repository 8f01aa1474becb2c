"""The few error types TAMP-OS raises. Each message names the file or parameter,
the allowed range, the value received and what to do, so the CLI can print it as is."""


class TampError(Exception):
    """Base class: a problem the user can fix; the CLI prints it without a traceback.

    Messages name parameters as the library does (`pixel_size`); the CLI and the web app say
    them in their own words. `in_file=True` marks a message about a file's own keys (a CSV
    column, a TOML key), which keep their names everywhere.
    """

    def __init__(self, message: str = "", *, in_file: bool = False):
        super().__init__(message)
        self.in_file = in_file


class InputError(TampError):
    """An input file that cannot be read or used."""


class ParameterError(TampError, ValueError):
    """A parameter outside its allowed range."""


class MissingDependencyError(TampError):
    """An optional tool or library that is not installed."""


class ExportError(TampError):
    """An output that cannot be written."""
