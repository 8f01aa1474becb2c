"""The web app in a Jupyter notebook: one server reused, stoppable, a titled frame, a clear failure,
a proxied address, and framing allowed for a notebook on this computer only."""

import http.server
import os
import socket
import threading

import httpx
import pytest

from conftest import need
from gui_support import CHROMIUM, LAUNCH_ARGS, png_bytes


@pytest.fixture
def launched():
    from tamp_os.gui import launch, stop_all

    handle = launch()
    yield handle
    stop_all()


@pytest.mark.timeout(60)
def test_launch_returns_a_reusable_stoppable_handle_shown_in_a_titled_frame(launched):
    from tamp_os.gui import launch

    assert launched.running and launched.url.startswith("http://127.0.0.1:")
    r = httpx.get(launched.url, timeout=10)
    assert r.status_code == 200 and "Make a tactile lithograph" in r.text
    csp = r.headers["content-security-policy"]
    assert "frame-ancestors 'self' http://localhost:* http://127.0.0.1:*" in csp and "x-frame-options" not in r.headers
    html = launched._repr_html_()
    assert '<iframe src="' + launched.url in html and 'title="TAMP-OS web app' in html
    again = launch()
    assert again is launched  # reused, not a second server
    launched.stop()
    assert not launched.running
    with pytest.raises(httpx.HTTPError):
        httpx.get(launched.url, timeout=2)


@pytest.mark.timeout(60)
def test_launch_says_clearly_when_the_server_cannot_start():
    from tamp_os.gui import launch

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        handle = launch(port=taken.getsockname()[1], timeout_s=5)
    assert not handle.running and handle.error
    html = handle._repr_html_()
    assert "<iframe" not in html and 'role="alert"' in html and "did not start" in html
    assert "port" in str(handle)


@pytest.mark.timeout(60)
def test_launch_behind_a_notebook_proxy_uses_the_prefix_in_every_link():
    from tamp_os.gui import launch, stop_all

    try:
        handle = launch(proxy="/user/ann/proxy/{port}")
        assert handle.url == f"/user/ann/proxy/{handle.port}/"
        page = httpx.get(f"http://127.0.0.1:{handle.port}/", timeout=10).text  # the proxy strips the prefix
        prefix = f"/user/ann/proxy/{handle.port}"
        assert f'href="{prefix}/static/style.css"' in page and f'action="{prefix}/jobs"' in page
        assert 'href="/static' not in page and 'action="/jobs' not in page
    finally:
        stop_all()


@pytest.mark.timeout(90)
def test_a_notebook_on_this_computer_may_frame_the_app_and_use_it(launched):
    need(os.path.exists(CHROMIUM), "Chromium (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    notebook = f'<!doctype html><html lang="en"><title>notebook</title>{launched._repr_html_()}</html>'.encode()

    class Notebook(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.end_headers()
            self.wfile.write(notebook)

        def log_message(self, *args):
            pass

    # A real local server (not a routed page: Chromium treats those as public and blocks local frames).
    notebook_server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Notebook)
    threading.Thread(target=notebook_server.serve_forever, daemon=True).start()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=LAUNCH_ARGS)
        page = browser.new_page()
        page.goto(f"http://localhost:{notebook_server.server_address[1]}/notebook")
        frame = page.frame_locator("iframe")
        frame.locator("h1").wait_for(timeout=20000)
        assert frame.locator("h1").inner_text() == "Make a tactile lithograph"
        path = os.path.join(os.environ.get("TMPDIR", "/tmp"), "tamp-notebook-test.png")
        with open(path, "wb") as fh:
            fh.write(png_bytes())
        frame.locator("#images").set_input_files(path)
        frame.get_by_role("button", name="Add images").click()
        frame.locator("h1:has-text('Step 2 of 3')").wait_for(timeout=30000)  # the form works inside the frame
        browser.close()
    notebook_server.shutdown()
