"""The web app inside a Jupyter notebook: one server per kernel, reused, stoppable, and shown
in a titled frame, directly or through a jupyter-server-proxy style prefix when the notebook runs
on another machine than the browser."""

from __future__ import annotations

import html
import logging
import os
import threading
import time
import urllib.request
from dataclasses import dataclass, field

log = logging.getLogger(__name__)
_RUNNING: dict[tuple[int, str], "Launched"] = {}
_LOCK = threading.Lock()
# Where a notebook on this computer is served from: it may frame the app, nobody else may.
NOTEBOOK_ORIGINS = ("'self'", "http://localhost:*", "http://127.0.0.1:*", "http://[::1]:*", "https://localhost:*")


@dataclass
class Launched:
    """A running (or failed) notebook server: `url` to open, `stop()` to end it, shown as a frame."""

    url: str
    port: int
    height: int = 900
    error: str = ""
    _server: object = field(default=None, repr=False)
    _thread: threading.Thread | None = field(default=None, repr=False)

    @property
    def running(self) -> bool:
        return not self.error and self._thread is not None and self._thread.is_alive()

    def stop(self, timeout_s: float = 10.0) -> None:
        """Stop the server; its job folders are deleted."""
        if self._server is not None:
            self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout_s)
        with _LOCK:
            for key, value in list(_RUNNING.items()):
                if value is self:
                    del _RUNNING[key]

    def _repr_html_(self) -> str:
        if self.error:
            return f'<p role="alert"><strong>The TAMP-OS web app did not start:</strong> {html.escape(self.error)}</p>'
        src = html.escape(self.url, quote=True)
        return (f'<iframe src="{src}" title="TAMP-OS web app: make tactile lithographs" width="100%" height="{int(self.height)}" '
                f'style="border: 1px solid #8a8a8a"></iframe>'
                f'<p>If the frame stays blank, open <a href="{src}" target="_blank" rel="noopener">the TAMP-OS web app</a> '
                "in its own tab; when the notebook runs on another computer, launch with proxy=True.</p>")

    def __str__(self) -> str:
        return self.url if not self.error else f"not running: {self.error}"


def launch(port: int | None = None, height: int = 900, proxy: bool | str | None = None, *, timeout_s: float = 20.0) -> Launched:
    """Start the web app in the background (or reuse the one already running) and show it.

    Parameters
    ----------
    port : the port on 127.0.0.1 (default: a free one; reused across calls).
    height : the frame's height in CSS pixels.
    proxy : True to reach the server through jupyter-server-proxy at
        ``{JUPYTERHUB_SERVICE_PREFIX or /}proxy/{port}/`` (for a notebook on another computer), or a
        prefix of your own containing ``{port}``; None or False: the browser reaches 127.0.0.1.
    timeout_s : how long to wait for the server to answer.

    Returns a `Launched`: displayed as a titled frame in a notebook; `.url`, `.stop()`.
    """
    from .server import free_port

    base_path = _proxy_prefix(proxy)
    with _LOCK:
        for (running_port, running_base), handle in list(_RUNNING.items()):
            if handle.running and running_base == (base_path or "") and port in (None, running_port):
                handle.height = height
                return handle
        port = port or free_port()
        base_path = base_path.format(port=port) if base_path else ""
        handle = _start(port, height, base_path, timeout_s)
        if handle.running:
            _RUNNING[(port, _proxy_prefix(proxy) or "")] = handle
    return handle


def _proxy_prefix(proxy: bool | str | None) -> str:
    if not proxy:
        return ""
    if isinstance(proxy, str):
        return proxy.rstrip("/")
    root = os.environ.get("JUPYTERHUB_SERVICE_PREFIX", "/").rstrip("/")
    return f"{root}/proxy/{{port}}"


def _start(port: int, height: int, base_path: str, timeout_s: float) -> Launched:
    from .server import make_server

    try:
        server = make_server("127.0.0.1", port, frame_ancestors=NOTEBOOK_ORIGINS, base_path=base_path)
    except Exception as exc:  # say it in the notebook instead of showing an empty frame
        return Launched("", port, height, error=f"{exc.__class__.__name__}: {exc}")
    thread = threading.Thread(target=_run_quietly, args=(server,), daemon=True, name=f"tamp-gui-{port}")
    thread.start()
    local = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and thread.is_alive():
        try:
            urllib.request.urlopen(local, timeout=0.5)
            return Launched(f"{base_path}/" if base_path else local, port, height, _server=server, _thread=thread)
        except OSError:
            time.sleep(0.1)
    server.should_exit = True
    why = "it stopped at once (is the port in use?)" if not thread.is_alive() else f"it did not answer within {timeout_s:g} s"
    return Launched("", port, height, error=f"port {port}: {why}. Try launch(port=...) with another port.")


def stop_all() -> None:
    """Stop every server this kernel started."""
    for handle in list(_RUNNING.values()):
        handle.stop()


def _run_quietly(server) -> None:
    """Run the server in its thread; a failure to start (port taken) ends the thread without a
    traceback in the notebook: launch() notices that the thread stopped and says so in words."""
    try:
        server.run()
    except (OSError, SystemExit):
        pass

