"""The web app: a FastAPI server with Jinja2 pages that work without JavaScript.

Flow: add images -> choose printer, detail (Low/Medium/High cards, with the suggestion and an
override per image), customize, formats -> Generate -> progress -> results with a description,
previews, a 3-D view and downloads. Safety (security.py): only this computer's host names, no
cross-site requests, a form token, capped bodies (chunked ones too), no framing; uploads decoded
off the event loop (uploads.py); names sanitized; each job in its own folder.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates
from starlette.exceptions import HTTPException as StarletteHTTPException

from .jobs import JobStore, file_purpose
from .security import BodyTooLarge, Guard, GuardMiddleware

HERE = Path(__file__).parent


@dataclasses.dataclass
class Limits:
    """How the server is set up: upload caps, where it listens, and who may frame it."""

    max_file_mb: float = 50.0
    max_files: int = 20
    max_decoded_mb: float = 150.0  # pixels once opened, in MB; the command line accepts more
    concurrent_decodes: int = 2
    host: str = "127.0.0.1"
    access_token: str | None = None
    frame_ancestors: tuple[str, ...] = ()
    base_path: str = ""  # URL prefix when served behind a notebook proxy, e.g. /user/ann/proxy/8765
    extra_hosts: tuple[str, ...] = ()  # host names besides this computer's that may reach the server

    @property
    def max_body_bytes(self) -> int:
        return int(self.max_file_mb * 1e6 * self.max_files + 1e6)


@dataclasses.dataclass
class Web:
    """What the routes share: settings, jobs, pages and the guard."""

    limits: Limits
    store: JobStore
    templates: Jinja2Templates
    guard: Guard
    decode_limiter: object = None  # an anyio CapacityLimiter, made when the server starts

    @property
    def base(self) -> str:
        return self.limits.base_path.rstrip("/")

    def page(self, request: Request, name: str, status: int = 200, **context) -> HTMLResponse:
        context.setdefault("errors", {})
        context.setdefault("summary", [])
        # an open page of a job asks for its status this often, so the job lives while the page is open
        keepalive_ms = max(300, int(self.store.grace_s * 1000 / 3))
        context.update(limits=self.limits, base=self.base, token=self.guard.form_token, keepalive_ms=keepalive_ms)
        return self.templates.TemplateResponse(request, name, context, status_code=status)

    def message(self, status: int, title: str, text: str) -> HTMLResponse:
        """A plain page with a title and one message, for refusals and errors."""
        html = self.templates.get_template("message.html").render(title=title, text=text, base=self.base, limits=self.limits)
        return HTMLResponse(html, status_code=status)


def plain_reason(text: str) -> str:
    """Drop the numeric scores that explain a suggestion to developers, not to users."""
    return re.sub(r" \(score [^)]*\)", "", text)


def store_from_environment() -> JobStore:
    # Operational knobs (the tests use them): where job folders live, how long a job is kept
    # after its zip is downloaded, and an artificial delay per image to observe progress.
    env = os.environ
    return JobStore(
        root=env.get("TAMP_GUI_ROOT") or None,
        grace_s=float(env.get("TAMP_GUI_GRACE_S", 60)),
        slow_s=float(env.get("TAMP_GUI_SLOW_S", 0)),
    )


def create_app(limits: Limits | None = None, store: JobStore | None = None) -> FastAPI:
    """The web app. `limits` sets caps, host and framing; `store` holds the jobs."""
    from . import routes

    limits = limits or Limits()
    guard = Guard(max_body_bytes=limits.max_body_bytes, host=limits.host, access_token=limits.access_token,
                  frame_ancestors=tuple(limits.frame_ancestors), proxied=bool(limits.base_path),
                  extra_hosts=tuple(h.lower() for h in limits.extra_hosts))
    templates = Jinja2Templates(directory=HERE / "templates")
    templates.env.filters["plain_reason"] = plain_reason
    templates.env.filters["file_purpose"] = file_purpose
    web = Web(limits, store or store_from_environment(), templates, guard)

    @contextlib.asynccontextmanager
    async def lifespan(app):
        import anyio

        web.decode_limiter = anyio.CapacityLimiter(max(1, limits.concurrent_decodes))
        yield
        web.store.close()  # the job folders go with the server

    app = FastAPI(title="TAMP-OS", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.state.store = web.store
    app.state.web = web
    app.mount("/static", StaticFiles(directory=HERE / "static"), name="static")
    _error_pages(app, web)
    routes.add_upload_routes(app, web)
    routes.add_job_routes(app, web)
    routes.add_again_route(app, web)
    routes.add_file_routes(app, web)
    app.add_middleware(GuardMiddleware, guard=guard, refuse=web.message)
    return app


def _error_pages(app: FastAPI, web: Web) -> None:
    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException):
        if exc.status_code == 404:
            return web.message(404, "Page not found", "There is no page at this address. Start again from the first page.")
        return web.message(exc.status_code, "Request refused", f"The request could not be handled ({exc.detail}). Go back and try again.")

    @app.exception_handler(BodyTooLarge)
    async def too_large(request: Request, exc: BodyTooLarge):
        return web.message(413, "Upload too large", f"The upload is larger than the {exc.limit_bytes / 1e6:.0f} MB this server accepts "
                                                     "at once. Choose fewer or smaller image files and try again.")
