"""The web app's server: a uvicorn Server on a loopback port, run until stopped."""

from __future__ import annotations

import signal
import socket
import threading


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def make_server(host: str = "127.0.0.1", port: int = 8765, **app_options):
    """A uvicorn Server for the app (not started); app_options are `Limits` fields."""
    import uvicorn

    from .app import Limits, create_app

    app = create_app(Limits(host=host, **app_options))
    return uvicorn.Server(uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="on"))


def serve(host: str = "127.0.0.1", port: int = 8765, on_ready=None, **app_options) -> None:
    """Run the server in this thread until stopped (Control-C, SIGTERM, or the terminal closing).
    `on_ready()` is called once the socket accepts connections: an address said before that would
    be refused to a user who opens it at once (on a loaded machine the app takes seconds to start)."""
    server = make_server(host, port, **app_options)
    if on_ready is not None:
        startup = server.startup

        async def startup_then_ready(sockets=None) -> None:
            await startup(sockets=sockets)
            if server.started:
                on_ready()

        server.startup = startup_then_ready
    if threading.current_thread() is threading.main_thread() and hasattr(signal, "SIGHUP"):
        # Closing the terminal sends SIGHUP, which would end the process without the shutdown
        # that deletes the uploaded images: treat it like Control-C.
        signal.signal(signal.SIGHUP, lambda *_: setattr(server, "should_exit", True))
    server.run()
