"""What keeps a local web server local: Host and Origin checks, a cap on request bodies that also
holds for chunked uploads, an access token when listening beyond this computer, a form token, and
headers that forbid framing.

Any web page the user visits can send requests to 127.0.0.1, so every check here runs before a
route sees the request. Written as plain ASGI middleware because the body cap has to count bytes
as they arrive, before anything is spooled to disk.
"""

from __future__ import annotations

import hmac
import ipaddress
import logging
import secrets
from dataclasses import dataclass, field
from urllib.parse import parse_qsl, urlencode, urlsplit

log = logging.getLogger(__name__)

LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
ACCESS_COOKIE = "tamp_access"


class BodyTooLarge(Exception):
    """A request body passed the byte cap while it was being received."""

    def __init__(self, limit_bytes: int):
        super().__init__(f"request body larger than {limit_bytes} bytes")
        self.limit_bytes = limit_bytes


def is_loopback(host: str) -> bool:
    """True for names and addresses that can only mean this computer."""
    if host in LOOPBACK_NAMES or host.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def host_name(netloc: str) -> str:
    """'example.org:80' -> 'example.org'; '[::1]:8765' -> '::1' (lower case)."""
    return (urlsplit("//" + netloc).hostname or "").lower()


@dataclass
class Guard:
    """The server's checks. `host` is the address it listens on; `access_token` is required from
    every client when set (the server then listens beyond this computer); `frame_ancestors` lists
    the origins allowed to frame the app (empty: nobody; the notebook launch sets it)."""

    max_body_bytes: int
    host: str = "127.0.0.1"
    access_token: str | None = None
    frame_ancestors: tuple[str, ...] = ()
    proxied: bool = False  # behind a notebook proxy: the browser's Origin is the notebook's
    extra_hosts: tuple[str, ...] = ()  # more host names to answer to (a proxy that forwards its own)
    form_token: str = field(default_factory=lambda: secrets.token_urlsafe(32))

    def host_allowed(self, netloc: str) -> bool:
        name = host_name(netloc)
        if is_loopback(name) or name in self.extra_hosts:
            return True
        configured = self.host.strip("[]").lower()
        if configured in ("0.0.0.0", "::", ""):
            return self.access_token is not None  # any name, but only with the token
        return name == configured

    def cross_site(self, headers: dict[str, str], netloc: str) -> bool:
        """True when a state-changing request comes from another site (or we cannot tell it does not)."""
        fetch_site = headers.get("sec-fetch-site")
        if fetch_site and fetch_site not in ("same-origin", "none"):
            return True
        origin = headers.get("origin")
        if origin is None or self.proxied:
            return False  # old browsers and tools send no Origin; the form token still applies
        parts = urlsplit(origin)
        return origin == "null" or parts.netloc.lower() != netloc.lower()

    def token_ok(self, sent: str | None) -> bool:
        return bool(sent) and hmac.compare_digest(sent, self.form_token)

    def security_headers(self) -> list[tuple[bytes, bytes]]:
        ancestors = " ".join(self.frame_ancestors) or "'none'"
        csp = (
            "default-src 'self'; img-src 'self' data: blob:; style-src 'self' 'unsafe-inline'; script-src 'self'; "
            f"connect-src 'self' blob: data:; object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors {ancestors}"
        )
        headers = [
            (b"content-security-policy", csp.encode()),
            (b"x-content-type-options", b"nosniff"),
            (b"referrer-policy", b"same-origin"),  # "no-referrer" makes Chromium send Origin: null on our own forms
            (b"cross-origin-resource-policy", b"same-origin"),
        ]
        if not self.frame_ancestors:
            headers.append((b"x-frame-options", b"DENY"))
        return headers


class GuardMiddleware:
    """ASGI middleware applying a Guard to every HTTP request."""

    def __init__(self, app, guard: Guard, refuse):
        self.app, self.guard, self.refuse = app, guard, refuse  # refuse(status, title, text) -> ASGI app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        send = self._with_headers(send)
        refusal = self._check(scope, headers)
        if refusal is not None:
            return await self.refuse(*refusal)(scope, receive, send)
        token = self._token_from_query(scope)
        if token is not None:
            return await self._accept_token(scope, send)
        if scope["method"] not in SAFE_METHODS:
            receive = self._capped(receive)
        await self._answering_errors(scope, receive, send)

    async def _answering_errors(self, scope, receive, send):
        """Run the app; an exception nobody handled becomes a plain 500 page sent through `send`
        (so it carries the security headers too), logged, and never a second response."""
        started = False

        async def tracking(message):
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        from starlette.requests import ClientDisconnect

        try:
            await self.app(scope, receive, tracking)
        except ClientDisconnect:  # a cancelled upload or a closed tab is normal: one line, and nobody to answer
            log.info("the browser left during %s %s", scope.get("method"), scope.get("path"))
        except Exception:
            log.exception("unexpected error answering %s %s", scope.get("method"), scope.get("path"))
            if not started:
                await self.refuse(500, "Something went wrong", "TAMP-OS could not answer this request because of an "
                                  "unexpected error. Go back and try again; if it happens again, please report it.")(scope, receive, send)

    def _check(self, scope, headers):
        g, netloc = self.guard, headers.get("host", "")
        if not g.host_allowed(netloc):
            return 421, "Wrong address", "This TAMP-OS server answers only at its own address. Open it from the address it printed when it started."
        if g.access_token and not self._has_access(headers, scope):
            return 403, "Access link needed", "This TAMP-OS server needs its access link. Use the full address, with ?token=…, that it printed when it started."
        if scope["method"] not in SAFE_METHODS:
            if g.cross_site(headers, netloc):
                return 403, "Request refused", "Another web site tried to send this request to TAMP-OS, so it was refused. Use the TAMP-OS page itself."
            length = headers.get("content-length", "")
            if length.isdigit() and int(length) > g.max_body_bytes:
                return 413, "Upload too large", _too_large_text(g.max_body_bytes)
        return None

    def _has_access(self, headers, scope) -> bool:
        cookies = dict(part.strip().split("=", 1) for part in headers.get("cookie", "").split(";") if "=" in part)
        sent = cookies.get(ACCESS_COOKIE) or self._token_from_query(scope)
        return bool(sent) and hmac.compare_digest(sent, self.guard.access_token)

    def _token_from_query(self, scope) -> str | None:
        if not self.guard.access_token:
            return None
        return dict(parse_qsl(scope.get("query_string", b"").decode("latin-1"))).get("token")

    async def _accept_token(self, scope, send):
        """Trade the token in the address for a cookie, and drop it from the address bar."""
        query = [(k, v) for k, v in parse_qsl(scope.get("query_string", b"").decode("latin-1")) if k != "token"]
        location = scope.get("root_path", "") + scope["path"] + ("?" + urlencode(query) if query else "")
        cookie = f"{ACCESS_COOKIE}={self.guard.access_token}; HttpOnly; SameSite=Strict; Path=/"
        await send({"type": "http.response.start", "status": 303,
                    "headers": [(b"location", location.encode()), (b"set-cookie", cookie.encode()), (b"content-length", b"0")]})
        await send({"type": "http.response.body", "body": b""})

    def _capped(self, receive):
        limit, seen = self.guard.max_body_bytes, 0

        async def capped():
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > limit:
                    raise BodyTooLarge(limit)  # stop reading: the rest is never spooled to disk
            return message

        return capped

    def _with_headers(self, send):
        extra = self.guard.security_headers()

        async def sending(message):
            if message["type"] == "http.response.start":
                message = {**message, "headers": [*message.get("headers", []), *extra]}
            await send(message)

        return sending


def only_text_fields(form, files: tuple[str, ...] = ()) -> None:
    """Refuse (400) a form in which a field other than `files` arrived as a file part: the routes
    read those fields as text, and a file there is a malformed (or hostile) form, not a 500."""
    from starlette.datastructures import UploadFile
    from starlette.exceptions import HTTPException

    for key, value in form.multi_items():
        if key not in files and isinstance(value, UploadFile):
            raise HTTPException(400, f"the form field {key[:40]!r} was sent as a file")


def _too_large_text(limit_bytes: int) -> str:
    return (f"The upload is larger than the {limit_bytes / 1e6:.0f} MB this server accepts at once. "
            "Choose fewer or smaller image files and try again.")
