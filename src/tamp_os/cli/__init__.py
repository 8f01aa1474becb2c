"""The `tamp-os` command line: `main` parses the arguments and runs a command (commands.py)."""

from .commands import main, run  # noqa: F401  (run: the console script's entry point; main: the same for callers)
