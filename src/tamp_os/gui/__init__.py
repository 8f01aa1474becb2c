"""The local web app (FastAPI + uvicorn). `launch()` shows it inside a Jupyter notebook."""

from __future__ import annotations

from .notebook import Launched, launch, stop_all  # noqa: F401  (the notebook API)
from .server import free_port, make_server, serve  # noqa: F401  (the server API)
