"""`python -m tamp_os.cli`: the same as the `tamp-os` command."""

import sys

from .commands import run

sys.exit(run())
