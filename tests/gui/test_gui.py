"""The web app, served for real and driven in a real headless Chromium (Playwright), with axe
(WCAG 2.2 AA tags) in every state, with and without JavaScript, at 1280 px, 320 px and 200 % zoom."""

import concurrent.futures
import io
import json
import shutil
import time
import zipfile

import httpx
import numpy as np
import pytest
import trimesh
from PIL import Image

from conftest import need
from gui_support import (audit, browser, form_token, generate_and_wait, new_job, no_sideways_scroll, png_bytes,
                         screenshot, start_server, stop_server, tab_to)

VIEWPORTS = {  # name: (browser context options)
    "1280": {"viewport": {"width": 1280, "height": 900}},
    "320": {"viewport": {"width": 320, "height": 640}},
    "zoom200": {"viewport": {"width": 640, "height": 450}, "device_scale_factor": 2},  # 1280 × 900 at 200 %
}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    root = tmp_path_factory.mktemp("gui-jobs")
    proc, url = start_server(root, "--max-file-mb", "2", slow_s=0.0)
    yield url, root
    stop_server(proc)


@pytest.fixture(scope="module")
def slow_server(tmp_path_factory):
    """A server whose jobs wait 0.8 s before each image, so the progress page can be audited and watched."""
    root = tmp_path_factory.mktemp("gui-slow-jobs")
    proc, url = start_server(root, "--max-file-mb", "2", slow_s=0.8)
    yield url, root
    stop_server(proc)


@pytest.fixture
def page(browser):
    context = browser.new_context(accept_downloads=True)
    pg = context.new_page()
    yield pg
    context.close()


def zip_stl(download_path):
    with zipfile.ZipFile(download_path) as z:
        names = z.namelist()
        stl = [n for n in names if n.endswith(".stl")]
        assert stl, names
        return trimesh.load(io.BytesIO(z.read(stl[0])), file_type="stl"), names


def images(tmp_path):
    """Two small images of different shapes (so per-image facts differ) and a text file."""
    paths = []
    for name, shape, seed in (("cells.png", (60, 80), 1), ("fibres.png", (40, 80), 2)):
        path = tmp_path / name
        path.write_bytes(png_bytes(shape, seed))
        paths.append(str(path))
    notes = tmp_path / "notes.png"
    notes.write_text("these are my notes, not an image")
    return paths, str(notes)


def check_state(page, state, auditor=None):
    """axe, reflow and a screenshot. axe needs JavaScript to run: without JavaScript the page's own
    HTML, as the no-JavaScript browser received it, is audited in `auditor`, a page whose own
    scripts are blocked, at the same size."""
    no_sideways_scroll(page, state)
    screenshot(page, state)
    if auditor is None:
        audit(page, state)
        return
    html = page.content()
    auditor.route(page.url, lambda route: route.fulfill(status=200, content_type="text/html", body=html))
    auditor.goto(page.url)
    auditor.unroute(page.url)
    audit(auditor, state)
    no_sideways_scroll(auditor, state)


def wait_until(page, expression: str, timeout_s: float = 30) -> None:
    """Poll an expression (the app's CSP forbids the eval behind page.wait_for_function)."""
    deadline = time.monotonic() + timeout_s
    while not page.evaluate(f"() => {expression}"):
        assert time.monotonic() < deadline, f"never true: {expression}"
        page.wait_for_timeout(200)


def finish(page, js: bool):
    """Reach the results: with JavaScript the page changes by itself; without, by Check progress."""
    if js:
        page.wait_for_selector("h1:has-text('Your lithographs')", timeout=60000)
        return
    for _ in range(120):  # bounded: the job takes a few seconds
        page.wait_for_load_state()  # the page a click asked for, loaded (not the one it leaves)
        if page.locator("h1:has-text('Your lithographs')").count():
            return
        page.wait_for_timeout(500)
        link = page.get_by_role("link", name="Check progress")
        if link.count():
            link.click()
    raise AssertionError("the job did not finish")


@pytest.mark.timeout(300)
@pytest.mark.parametrize("js", [True, False], ids=["js", "nojs"])
def test_every_state_passes_axe_and_reflows_in_every_viewport(slow_server, browser, tmp_path, js):
    """One job through every state, each state audited and checked for reflow in every viewport
    (the page resized in place: 200 % zoom is the 640 CSS px viewport, which is what reflow and
    axe see; a job per viewport would only repeat the conversion)."""
    url, _ = slow_server
    mode = "js" if js else "nojs"
    context = browser.new_context(java_script_enabled=js, **VIEWPORTS["1280"])
    page = context.new_page()
    auditor = None
    if not js:
        auditor = browser.new_context(**VIEWPORTS["1280"]).new_page()
        auditor.route("**/static/app.js", lambda route: route.abort())
        auditor.route("**/static/vendor/**", lambda route: route.abort())

    def check_every_viewport(state):
        for view, options in VIEWPORTS.items():
            page.set_viewport_size(options["viewport"])
            if auditor is not None:
                auditor.set_viewport_size(options["viewport"])
            check_state(page, f"{view}-{mode}-{state}", auditor)
        page.set_viewport_size(VIEWPORTS["1280"]["viewport"])

    good, notes = images(tmp_path)
    page.goto(url)
    check_every_viewport("1-empty")
    page.set_input_files("#images", notes)
    page.get_by_role("button", name="Add images").click()
    check_every_viewport("2-upload-error")
    page.set_input_files("#images", good)
    page.get_by_role("button", name="Add images").click()
    page.wait_for_selector("h1:has-text('Step 2 of 3')", timeout=60000)
    check_every_viewport("3-settings")
    page.locator("summary").click()
    page.fill("#relief_mm", "0")
    page.fill("#width_mm", "abc")
    page.get_by_role("button", name="Generate").click()
    check_every_viewport("4-settings-errors")
    page.fill("#relief_mm", "2")
    page.fill("#width_mm", "")
    page.get_by_role("button", name="Generate").click()
    page.wait_for_selector("#progress")
    assert page.locator("meta[http-equiv=refresh]").count() == 0
    check_every_viewport("5-progress")
    finish(page, js)
    if js:
        wait_until(page, "customElements.get('model-viewer') !== undefined")
        page.wait_for_timeout(1500)  # let the 3D view draw before the screenshot
    check_every_viewport("6-results")
    if auditor is not None:
        auditor.context.close()
    context.close()


@pytest.mark.timeout(180)
def test_results_describe_each_image_in_words(server, page, tmp_path):
    url, _ = server
    good, _ = images(tmp_path)
    page.goto(url)
    page.set_input_files("#images", good)
    page.get_by_role("button", name="Add images").click()
    page.wait_for_selector("h1:has-text('Step 2 of 3')", timeout=60000)
    # Per-image facts: each image's own grid, and its thumbnail.
    medium = page.locator("#preset-medium-facts").inner_text()
    assert "cells.png: grid 250 × 188" in medium and "fibres.png: grid 250 × 125" in medium, medium
    assert page.locator(".upload img").count() == 2
    # A thumbnail decodes after the page shows; wait for both to finish loading (a broken one ends complete
    # with width 0, so the assertion after the wait still fails on it).
    page.wait_for_function("[...document.querySelectorAll('.upload img')].every(i => i.complete)", timeout=30000)
    assert all(page.evaluate(f"document.querySelectorAll('.upload img')[{i}].naturalWidth") > 0 for i in range(2))
    assert page.locator(".card.selected #preset-medium").count() == 1
    assert "score" not in page.locator("main").inner_text()
    headings = page.locator("h1, h2, h3").all_inner_texts()
    assert len(headings) >= 10 and headings[0].startswith("Step 2 of 3"), headings
    page.get_by_role("button", name="Generate").click()
    page.wait_for_selector("h1:has-text('Your lithographs')", timeout=60000)
    for i in (1, 2):
        description = page.locator(f"#description-{i}").inner_text()
        assert "mm wide" in description and "raised" in description, description
        section = page.locator("section.result").nth(i - 1)
        alts = [section.locator("img").nth(k).get_attribute("alt") for k in range(section.locator("img").count())]
        alts.append(section.locator("model-viewer").get_attribute("alt"))
        # Each description is read once (issue 24): the pictures get short alt text that points to it.
        assert alts and all(description not in alt and "described above" in alt and len(alt) < 120 for alt in alts), alts
        assert section.inner_text().count(description) == 1
        downloads = section.locator(".downloads li").all_inner_texts()
        assert downloads and all(t.rstrip().endswith(("kB)", "MB)", "bytes)")) for t in downloads), downloads
    glb = page.locator("model-viewer").first.get_attribute("src")
    r = httpx.get(url + glb, timeout=30)
    assert r.status_code == 200 and r.content[:4] == b"glTF"


@pytest.mark.timeout(180)
def test_the_same_flow_by_keyboard_alone_keeps_focus_on_the_progress_page(slow_server, page, fixture):
    url, _ = slow_server
    page.goto(url)

    tab_to(page, lambda i: i["id"] == "images", limit=80)
    # Space on a focused file input opens the chooser; headless Chromium now and then ignores the
    # first key press right after load, so press it again (still keyboard only) if nothing opened.
    from playwright.sync_api import TimeoutError as PlaywrightTimeout

    for attempt in range(3):
        try:
            with page.expect_file_chooser(timeout=5000) as chooser:
                page.keyboard.press("Space")
            break
        except PlaywrightTimeout:
            assert attempt < 2, "the file chooser never opened from the keyboard"
    chooser.value.set_files([str(fixture("fept_spheres_sem.png")), str(fixture("test_tiff_Zeiss_SEM_1k.tif"))])
    tab_to(page, lambda i: i["text"] == "Add images", limit=80)
    page.keyboard.press("Enter")
    page.wait_for_selector("text=Step 2 of 3", timeout=60000)
    tab_to(page, lambda i: i["id"].startswith("preset-"), limit=80)
    page.keyboard.press("ArrowLeft")  # arrow keys move within the radio group: Medium -> Low
    assert page.evaluate("document.activeElement.id") == "preset-low"
    tab_to(page, lambda i: i["text"] == "Generate", limit=80)
    page.keyboard.press("Enter")
    page.wait_for_selector("#progress")
    page.evaluate("window.stillTheSamePage = true")  # gone if the page reloads
    page.keyboard.press("Tab")  # focus somewhere on the progress page; it must stay there
    focused = page.evaluate("document.activeElement.tagName")
    announced = []
    for _ in range(240):  # bounded: at most about a minute
        announced.append(page.locator("#job-status").inner_text())
        now_focused = page.evaluate("document.activeElement.tagName")  # read before the results are looked for:
        if page.locator("h1:has-text('Your lithographs')").count():  # results shown between the two move focus on purpose
            break
        assert now_focused == focused, "focus was reset while waiting"
        page.wait_for_timeout(250)
    wait_until(page, "document.getElementById('job-status').textContent.startsWith('Done')")
    assert page.evaluate("window.stillTheSamePage === true"), "the progress page reloaded"
    assert page.evaluate("document.activeElement.id") == "page-title"  # focus moved to the results heading
    assert any(t.startswith("Converting") for t in announced), announced
    assert page.locator("#job-status").get_attribute("role") == "status"
    assert page.locator("#job-status").inner_text().startswith("Done: 2 of 2 converted")
    tab_to(page, lambda i: i["text"] == "Download everything (zip)", limit=80)
    with page.expect_download(timeout=60000) as download:
        page.keyboard.press("Enter")
    mesh, names = zip_stl(download.value.path())
    assert mesh.is_watertight and "fept_spheres_sem.tamp.json" in names
    assert json.loads(zipfile.ZipFile(download.value.path()).read("fept_spheres_sem.tamp.json"))["params"]["preset"] == "low"


@pytest.mark.timeout(120)
def test_without_javascript_there_is_no_automatic_refresh(server, browser, tmp_path):
    url, _ = server
    context = browser.new_context(java_script_enabled=False, accept_downloads=True)
    page = context.new_page()
    good, _ = images(tmp_path)
    page.goto(url)
    page.set_input_files("#images", good[0])
    page.get_by_role("button", name="Add images").click()
    page.get_by_role("button", name="Generate").click()
    page.wait_for_selector("#progress")
    assert page.locator("meta[http-equiv=refresh]").count() == 0 and page.get_by_role("link", name="Check progress").count() == 1
    before = page.url
    page.wait_for_timeout(2500)
    assert page.url == before and page.locator("#progress").count() == 1  # still here: nothing reloaded it
    finish(page, js=False)
    assert page.get_by_role("link", name="Download everything (zip)").count() == 1
    context.close()


@pytest.mark.timeout(120)
def test_errors_are_all_reported_at_once_in_plain_words(server, page, tmp_path):
    url, _ = server
    text = tmp_path / "notes.png"
    text.write_text("these are my notes, not an image")
    page.goto(url)
    page.set_input_files("#images", str(text))
    page.get_by_role("button", name="Add images").click()
    error = page.locator("#images-error").inner_text()
    assert "notes.png is not an image TAMP-OS can read" in error and "b'" not in error
    assert page.get_attribute("#images", "aria-invalid") == "true"
    assert "images-error" in page.get_attribute("#images", "aria-describedby")
    assert page.evaluate("document.activeElement.id") == "error-summary"
    assert page.title().startswith("Error:")
    order = page.evaluate("[...document.querySelectorAll('h1, h2')].map(h => h.tagName)")
    assert order[0] == "H1", order  # the error summary's h2 comes after the page's h1
    big = tmp_path / "big.png"
    Image.fromarray((np.random.default_rng(0).random((1400, 1400, 3)) * 255).astype(np.uint8)).save(big)
    page.set_input_files("#images", str(big))
    page.get_by_role("button", name="Add images").click()
    assert "larger than the limit of 2 MB" in page.locator("#images-error").inner_text()
    good = tmp_path / "good.png"
    good.write_bytes(png_bytes())
    page.set_input_files("#images", str(good))
    page.get_by_role("button", name="Add images").click()
    page.locator("summary").click()
    page.fill("#relief_mm", "0")
    page.fill("#width_mm", "abc")
    page.fill("#resolution_px", "2.5")
    page.get_by_role("button", name="Generate").click()
    summary = page.locator("#error-summary li").all_inner_texts()
    assert len(summary) == 3, summary
    assert page.locator("#error-summary h2").inner_text() == "There are 3 problems"
    relief = page.locator("#relief_mm-error").inner_text()
    assert "Relief height (mm)" in relief and "above 0 and up to 50 mm" in relief and "relief_mm" not in relief
    assert "Print width (mm)" in page.locator("#width_mm-error").inner_text()
    assert "whole number" in page.locator("#resolution_px-error").inner_text()
    assert all(page.get_attribute(f"#{f}", "aria-invalid") == "true" for f in ("relief_mm", "width_mm", "resolution_px"))
    page.fill("#relief_mm", "2")
    page.fill("#width_mm", "")
    page.fill("#resolution_px", "")
    page.get_by_role("button", name="Generate").click()
    page.wait_for_selector("text=Your lithographs", timeout=60000)


@pytest.mark.timeout(120)
def test_update_with_a_graphic_format_ticked_keeps_the_page_working(server, page, tmp_path):
    """Bug: ticking SVG or PDF and pressing "Update the detail choices" gave HTTP 500, and so did
    every later visit to that job's page."""
    url, _ = server
    good = tmp_path / "good.png"
    good.write_bytes(png_bytes())
    page.goto(url)
    page.set_input_files("#images", str(good))
    page.get_by_role("button", name="Add images").click()
    page.wait_for_selector("text=Step 2 of 3", timeout=60000)
    page.check("#format-svg")
    page.check("#format-pdf")
    with page.expect_response(lambda r: r.request.method == "POST") as posted:
        page.get_by_role("button", name="Update the detail choices for this printer").click()
    assert posted.value.status < 500, posted.value.status
    page.wait_for_selector("text=Step 2 of 3")
    cards = page.locator("main").inner_text()
    assert "SVG not estimated" in cards and "STL about" in cards, cards
    assert page.is_checked("#format-svg") and page.is_checked("#format-pdf")
    job_page = page.url.rsplit("/", 1)[0]  # the form posted to /jobs/ID/generate; the job's own page is /jobs/ID
    again = page.goto(job_page)
    assert again.status == 200 and "Step 2 of 3" in page.locator("main").inner_text()
    audit(page, "update-with-svg")


@pytest.mark.timeout(60)
def test_too_many_files_is_an_html_page_with_a_title(server):
    url, _ = server
    with httpx.Client(base_url=url, timeout=30) as client:
        token = form_token(client)
        files = [("images", (f"f{i}.png", png_bytes((8, 8), i), "image/png")) for i in range(22)]
        r = client.post("/jobs", data={"token": token}, files=files)
    assert r.status_code == 400 and r.headers["content-type"].startswith("text/html")
    assert "<title>Error: Add images" in r.text and "at most 20" in r.text and '"detail"' not in r.text
    assert httpx.get(url + "/no/such/page", timeout=10).text.count("<title>Page not found") == 1


def _one_job(url, i):
    with httpx.Client(base_url=url, timeout=120, follow_redirects=False) as client:
        buf = io.BytesIO()
        width = 40 + i  # each job's image has its own shape, so results cannot be confused
        Image.fromarray((np.random.default_rng(i).random((30, width)) * 255).astype(np.uint8)).save(buf, "PNG")
        job = new_job(client, [(f"job{i}.png", buf.getvalue())])
        generate_and_wait(client, job, printer="standard")
        z = client.get(f"/jobs/{job}/download.zip")
        assert z.status_code == 200
        with zipfile.ZipFile(io.BytesIO(z.content)) as archive:
            assert f"job{i}.stl" in archive.namelist()
            mesh = trimesh.load(io.BytesIO(archive.read(f"job{i}.stl")), file_type="stl")
        return i, mesh.bounds[1][1], 100 * 30 / width


@pytest.mark.timeout(300)
def test_twenty_concurrent_jobs_each_get_their_own_result(server):
    url, _ = server
    with concurrent.futures.ThreadPoolExecutor(20) as pool:
        results = list(pool.map(lambda i: _one_job(url, i), range(20)))
    for i, depth, expected in results:
        assert depth == pytest.approx(expected, abs=1e-3), i


@pytest.mark.timeout(120)
def test_no_path_traversal_and_jobs_are_cleaned_up(server, tmp_path):
    url, root = server
    with httpx.Client(base_url=url, timeout=60) as client:
        buf = io.BytesIO()
        Image.fromarray(np.eye(20, dtype=np.uint8) * 255).save(buf, "PNG")
        job = new_job(client, [("../../evil name.png", buf.getvalue())])
        page = client.get(f"/jobs/{job}").text
        assert "evil_name.png" in page and "../" not in page.split('class="uploads"')[1].split("</ul>")[0]
        assert (root / job / "in" / "evil_name.png").is_file()
        for bad in ("..%2F..%2Fetc%2Fpasswd", "%2Fetc%2Fpasswd", "evil_name.png"):
            assert client.get(f"/jobs/{job}/files/{bad}").status_code == 404  # only outputs are served
            assert client.get(f"/jobs/{job}/thumbs/{bad}").status_code == 404
        assert client.get("/jobs/not-a-job").status_code in (303, 307)
        generate_and_wait(client, job)
        assert client.get(f"/jobs/{job}/download.zip").status_code == 200
        deadline = time.monotonic() + 10
        while (root / job).exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not (root / job).exists()
        assert client.get(f"/jobs/{job}/status").status_code == 404


@pytest.mark.timeout(120)
def test_slicing_from_the_web_app(server):
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer")
    url, _ = server
    with httpx.Client(base_url=url, timeout=120) as client:
        job = new_job(client, [("p.png", png_bytes((30, 40), 5))])
        generate_and_wait(client, job, gcode="on")
        page = client.get(f"/jobs/{job}").text
        assert "Printing:" in page and "g of PLA" in page and "p.gcode" in page


@pytest.mark.timeout(30)
def test_port_in_use_is_a_clear_message(capsys):
    import socket

    from tamp_os.cli.commands import main

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main(["gui", "--no-browser", "--port", str(port)]) == 2
    assert "choose another port with --port" in capsys.readouterr().err


@pytest.mark.timeout(120)
def test_per_image_override_applies_to_that_image_only(server):
    url, _ = server
    with httpx.Client(base_url=url, timeout=120) as client:
        job = new_job(client, [(f"img{i}.png", png_bytes((30, 40), 10 + i)) for i in range(2)])
        generate_and_wait(client, job, override_1="high")
        page = client.get(f"/jobs/{job}").text
        assert "Grid 125 × 94 points" in page and "Grid 500 × 375 points" in page
