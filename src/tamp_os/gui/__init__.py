"""The local web app (FastAPI + uvicorn). `launch()` shows it inside a Jupyter notebook."""

from __future__ import annotations

import socket
import threading


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def serve(host: str = "127.0.0.1", port: int = 8765, **app_options):
    """Run the server in this thread until stopped."""
    import uvicorn

    from .app import Limits, create_app

    uvicorn.run(create_app(Limits(**app_options)), host=host, port=port, log_level="warning")


def launch(port: int | None = None, height: int = 900):
    """Start the server in the background and show it in the notebook (or return its address)."""
    import time
    import urllib.request

    port = port or free_port()
    threading.Thread(target=serve, kwargs={"port": port}, daemon=True).start()
    url = f"http://127.0.0.1:{port}/"
    for _ in range(100):
        try:
            urllib.request.urlopen(url, timeout=0.5)
            break
        except OSError:
            time.sleep(0.1)
    try:
        from IPython.display import IFrame

        return IFrame(url, width="100%", height=height)
    except ImportError:
        return url
