"""The `tamp-os` command line: `main` parses the arguments and runs a command (commands.py)."""

from .commands import main  # noqa: F401  (the console script's entry point)
