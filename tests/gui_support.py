"""Shared helpers of the web-app tests: a real server in a subprocess, headless Chromium, axe."""

from __future__ import annotations

import io
import os
import re
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image

from conftest import need

CHROMIUM = "/usr/bin/chromium"
LAUNCH_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
               "--disable-sync", "--no-first-run", "--disable-dev-shm-usage"]
WCAG_TAGS = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa", "wcag22aa"]
# Screenshots of every state, to look at, when $TAMP_SCREENSHOTS names a folder for them (full-page
# screenshots of every state in every viewport took a fifth of the accessibility matrix's time).
SCREENS = Path(os.environ["TAMP_SCREENSHOTS"]) if os.environ.get("TAMP_SCREENSHOTS") else None


def start_server(root: Path, *extra: str, slow_s: float = 0.0, grace_s: float = 1.0):
    """Start `tamp-os gui` for real; returns (process, url). Waits at most 60 s (a loaded machine)."""
    from tamp_os.gui import free_port

    port = free_port()
    env = dict(os.environ, TAMP_GUI_ROOT=str(root), TAMP_GUI_SLOW_S=str(slow_s), TAMP_GUI_GRACE_S=str(grace_s))
    proc = subprocess.Popen([sys.executable, "-m", "tamp_os.cli.commands", "gui", "--no-browser", "--port", str(port), *extra],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            httpx.get(url, timeout=0.5)
            return proc, url
        except httpx.HTTPError:
            time.sleep(0.1)
    proc.kill()
    pytest.fail(f"the server did not start: {proc.stdout.read()}")


def stop_server(proc) -> None:
    proc.terminate()
    proc.wait(timeout=10)


def form_token(client: httpx.Client, path: str = "/") -> str:
    """The form token a page carries (what a same-origin page can read and a foreign one cannot)."""
    return re.search(r'name="token" value="([^"]+)"', client.get(path).text).group(1)


def png_bytes(shape=(30, 40), seed=0) -> bytes:
    buf = io.BytesIO()
    Image.fromarray((np.random.default_rng(seed).random(shape) * 255).astype(np.uint8)).save(buf, "PNG")
    return buf.getvalue()


def bomb_png(side_px: int = 19500) -> bytes:
    """A valid 8-bit grey PNG of side_px × side_px black pixels in a few hundred kilobytes."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    row, packer, parts = b"\0" * (side_px + 1), zlib.compressobj(9), []
    for start in range(0, side_px, 500):
        parts.append(packer.compress(row * min(500, side_px - start)))
    parts.append(packer.flush())
    header = struct.pack(">IIBBBBB", side_px, side_px, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", b"".join(parts)) + chunk(b"IEND", b"")


def new_job(client: httpx.Client, files: list[tuple[str, bytes]]) -> str:
    token = form_token(client)
    r = client.post("/jobs", data={"token": token}, files=[("images", (n, b, "image/png")) for n, b in files])
    assert r.status_code == 303, r.text
    return r.headers["location"].rsplit("/", 1)[1]


def generate_and_wait(client: httpx.Client, job: str, timeout_s: float = 120, **fields) -> None:
    token = form_token(client, f"/jobs/{job}")
    r = client.post(f"/jobs/{job}/generate", data={"token": token, "preset": "low", "formats": "stl", **fields})
    assert r.status_code == 303, r.text
    deadline = time.monotonic() + timeout_s
    while client.get(f"/jobs/{job}/status").json()["state"] != "done":
        assert time.monotonic() < deadline, "the job did not finish"
        time.sleep(0.2)


def audit(page, state: str) -> None:
    """axe with the WCAG 2.2 AA tags: no violation allowed.

    axe is injected once per loaded document (not before every run, as the wrapper library does) and
    only its violations cross back to Python: the same audit, about half the time."""
    from axe_playwright_python.base import AXE_SCRIPT, AxeResults

    if not page.evaluate("() => typeof window.axe !== 'undefined'"):
        page.evaluate(AXE_SCRIPT)
    options = {"runOnly": {"type": "tag", "values": WCAG_TAGS}, "resultTypes": ["violations"]}
    violations = page.evaluate("options => axe.run(document, options).then(r => r.violations)", options)
    assert not violations, f"{state}: {AxeResults({'violations': violations}).generate_report()}"


def no_sideways_scroll(page, state: str) -> None:
    width = page.evaluate("[document.documentElement.scrollWidth, window.innerWidth]")
    assert width[0] <= width[1] + 1, f"{state}: the page is {width[0]} px wide in a {width[1]} px window"


def screenshot(page, name: str) -> None:
    if SCREENS is None:
        return
    SCREENS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SCREENS / f"{name}.png"), full_page=True)

@pytest.fixture(scope="module")
def browser():
    """Debian's Chromium through Playwright, one per test module (import it into the module)."""
    need(os.path.exists(CHROMIUM), "Chromium (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=LAUNCH_ARGS)
        yield b
        b.close()


def tab_to(page, predicate, limit=120):
    """Press Tab until the focused element satisfies `predicate` (its id, text and outline style),
    checking that focus is visible there; fail when `limit` presses do not reach it. Returns its info."""
    return _tab_until(page, predicate, limit)[0]


def tabs_to(page, predicate, limit=60) -> int:
    """As `tab_to`, but returns how many Tab presses it took (a flow's keyboard cost)."""
    return _tab_until(page, predicate, limit)[1]


def _tab_until(page, predicate, limit: int) -> tuple[dict, int]:
    for pressed in range(1, limit + 1):
        page.keyboard.press("Tab")
        info = page.evaluate("() => ({id: document.activeElement.id, text: document.activeElement.textContent.trim(),"
                             " outline: getComputedStyle(document.activeElement).outlineStyle})")
        if predicate(info):
            assert info["outline"] != "none", f"no visible focus on {info}"
            return info, pressed
    raise AssertionError("could not reach the control by Tab")
