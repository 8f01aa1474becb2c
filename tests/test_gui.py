"""The web app, served for real and driven in a real headless Chromium (Playwright), with axe."""

import concurrent.futures
import io
import os
import shutil
import subprocess
import sys
import time
import zipfile

import httpx
import numpy as np
import pytest
import trimesh
from PIL import Image

from conftest import need

CHROMIUM = "/usr/bin/chromium"
LAUNCH_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
               "--disable-sync", "--no-first-run", "--disable-dev-shm-usage"]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    from tamp_os.gui import free_port

    root = tmp_path_factory.mktemp("gui-jobs")
    port = free_port()
    env = dict(os.environ, TAMP_GUI_ROOT=str(root), TAMP_GUI_SLOW_S="0.8", TAMP_GUI_GRACE_S="1")
    proc = subprocess.Popen([sys.executable, "-m", "tamp_os.cli", "gui", "--no-browser", "--port", str(port), "--max-file-mb", "2"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    url = f"http://127.0.0.1:{port}"
    for _ in range(100):
        try:
            httpx.get(url, timeout=0.5)
            break
        except httpx.HTTPError:
            time.sleep(0.1)
    else:
        proc.kill()
        pytest.fail(f"the server did not start: {proc.stdout.read()}")
    yield url, root
    proc.terminate()
    proc.wait(timeout=10)


@pytest.fixture(scope="module")
def browser():
    need(os.path.exists(CHROMIUM), "Chromium (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=LAUNCH_ARGS)
        yield b
        b.close()


@pytest.fixture
def page(browser):
    context = browser.new_context(accept_downloads=True)
    pg = context.new_page()
    yield pg
    context.close()


def audit(page, state):
    from axe_playwright_python.sync_playwright import Axe

    results = Axe().run(page)
    assert results.violations_count == 0, f"{state}: {results.generate_report()}"


def zip_stl(download_path):
    with zipfile.ZipFile(download_path) as z:
        names = z.namelist()
        stl = [n for n in names if n.endswith(".stl")]
        assert stl, names
        return trimesh.load(io.BytesIO(z.read(stl[0])), file_type="stl"), names


def test_whole_flow_with_axe_on_every_state(server, page, fixture, tmp_path):
    url, _ = server
    page.goto(url)
    audit(page, "empty")
    page.set_input_files("#images", str(fixture("fept_spheres_sem.png")))
    page.get_by_role("button", name="Add images").click()
    page.wait_for_selector("text=Step 2 of 3", timeout=60000)
    audit(page, "images added")
    assert page.locator("td", has_text="Medium").count() + page.locator("td", has_text="Low").count() + page.locator("td", has_text="High").count() >= 1
    page.locator("summary").click()
    page.wait_for_selector("#width_mm", state="visible")
    audit(page, "customization open")
    page.check("#preset-high")
    page.get_by_role("button", name="Generate").click()
    page.wait_for_selector("#progress")
    audit(page, "running")
    page.wait_for_selector("text=Your lithographs", timeout=60000)
    audit(page, "done")
    images = page.locator("figure img")
    assert images.count() == 2 and all(images.nth(i).get_attribute("alt") for i in range(2))
    with page.expect_download(timeout=60000) as download:
        page.get_by_role("link", name="Download everything (zip)").click()
    mesh, names = zip_stl(download.value.path())
    assert any(n.endswith(".3mf") for n in names) is False and "fept_spheres_sem.tamp.json" in names
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    np.testing.assert_allclose(mesh.bounds, [[0, 0, 0], [100, 75, 4]], atol=1e-3)
    import json

    recipe = json.loads(zipfile.ZipFile(download.value.path()).read("fept_spheres_sem.tamp.json"))
    assert recipe["params"]["preset"] == "high"


def test_the_same_flow_by_keyboard_alone(server, page, fixture):
    url, _ = server
    page.goto(url)

    def tab_to(predicate, limit=60):
        for _ in range(limit):
            page.keyboard.press("Tab")
            info = page.evaluate("() => ({id: document.activeElement.id, text: document.activeElement.textContent.trim(),"
                                 " outline: getComputedStyle(document.activeElement).outlineStyle})")
            if predicate(info):
                assert info["outline"] != "none", f"no visible focus on {info}"
                return info
        raise AssertionError("could not reach the control by Tab")

    tab_to(lambda i: i["id"] == "images")
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
    chooser.value.set_files(str(fixture("fept_spheres_sem.png")))
    tab_to(lambda i: i["text"] == "Add images")
    page.keyboard.press("Enter")
    page.wait_for_selector("text=Step 2 of 3", timeout=60000)
    tab_to(lambda i: i["id"].startswith("preset-"))
    page.keyboard.press("ArrowLeft")  # arrow keys move within the radio group: Medium -> Low
    assert page.evaluate("document.activeElement.id") == "preset-low"
    tab_to(lambda i: i["text"] == "Generate")
    page.keyboard.press("Enter")
    page.wait_for_selector("text=Your lithographs", timeout=60000)
    tab_to(lambda i: i["text"] == "Download everything (zip)")
    with page.expect_download(timeout=60000) as download:
        page.keyboard.press("Enter")
    mesh, _ = zip_stl(download.value.path())
    assert mesh.is_watertight
    np.testing.assert_allclose(mesh.bounds[1][:2], [100, 75], atol=1e-3)


def test_without_javascript(server, browser, fixture):
    url, _ = server
    context = browser.new_context(java_script_enabled=False, accept_downloads=True)
    page = context.new_page()
    page.goto(url)
    page.set_input_files("#images", str(fixture("fept_spheres_sem.png")))
    page.get_by_role("button", name="Add images").click()
    page.get_by_role("button", name="Generate").click()
    page.wait_for_selector("text=Your lithographs", timeout=60000)  # reached through the meta refresh
    assert page.get_by_role("link", name="Download everything (zip)").count() == 1
    context.close()


def test_errors_are_clear_tied_to_their_field_and_accessible(server, page, tmp_path):
    url, _ = server
    text = tmp_path / "notes.png"
    text.write_text("these are my notes, not an image")
    page.goto(url)
    page.set_input_files("#images", str(text))
    page.get_by_role("button", name="Add images").click()
    error = page.locator("#images-error")
    assert "notes.png" in error.inner_text() and "not an image" in error.inner_text()
    assert page.get_attribute("#images", "aria-invalid") == "true"
    assert "images-error" in page.get_attribute("#images", "aria-describedby")
    assert page.evaluate("document.activeElement.id") == "error-summary"
    audit(page, "error")
    big = tmp_path / "big.png"
    Image.fromarray((np.random.default_rng(0).random((1400, 1400, 3)) * 255).astype(np.uint8)).save(big)
    assert big.stat().st_size > 2e6
    page.set_input_files("#images", str(big))
    page.get_by_role("button", name="Add images").click()
    assert "larger than the limit of 2 MB" in page.locator("#images-error").inner_text()
    # A bad parameter is reported on its own field.
    page.set_input_files("#images", str(tmp_path / "notes.png").replace("notes", "notes"))
    good = tmp_path / "good.png"
    Image.fromarray((np.random.default_rng(1).random((30, 40)) * 255).astype(np.uint8)).save(good)
    page.set_input_files("#images", str(good))
    page.get_by_role("button", name="Add images").click()
    page.locator("summary").click()
    page.fill("#relief_mm", "0")
    page.get_by_role("button", name="Generate").click()
    assert "relief_mm" in page.locator("#relief_mm-error").inner_text()
    assert page.get_attribute("#relief_mm", "aria-invalid") == "true"
    audit(page, "parameter error")
    # And nothing broke: the same job still converts.
    page.fill("#relief_mm", "2")
    page.get_by_role("button", name="Generate").click()
    page.wait_for_selector("text=Your lithographs", timeout=60000)


def _one_job(url, i):
    with httpx.Client(base_url=url, timeout=120, follow_redirects=False) as client:
        buf = io.BytesIO()
        width = 40 + i  # each job's image has its own shape, so results cannot be confused
        Image.fromarray((np.random.default_rng(i).random((30, width)) * 255).astype(np.uint8)).save(buf, "PNG")
        r = client.post("/jobs", files={"images": (f"job{i}.png", buf.getvalue(), "image/png")})
        assert r.status_code == 303, r.text
        job = r.headers["location"].rsplit("/", 1)[1]
        r = client.post(f"/jobs/{job}/generate", data={"preset": "low", "printer": "standard", "formats": "stl"})
        assert r.status_code == 303
        for _ in range(600):
            state = client.get(f"/jobs/{job}/status").json()
            if state["state"] == "done":
                break
            time.sleep(0.2)
        z = client.get(f"/jobs/{job}/download.zip")
        assert z.status_code == 200
        with zipfile.ZipFile(io.BytesIO(z.content)) as archive:
            assert f"job{i}.stl" in archive.namelist()
            mesh = trimesh.load(io.BytesIO(archive.read(f"job{i}.stl")), file_type="stl")
        return i, mesh.bounds[1][1], 100 * 30 / width


def test_twenty_concurrent_jobs_each_get_their_own_result(server):
    url, _ = server
    with concurrent.futures.ThreadPoolExecutor(20) as pool:
        results = list(pool.map(lambda i: _one_job(url, i), range(20)))
    for i, depth, expected in results:
        assert depth == pytest.approx(expected, abs=1e-3), i


def test_no_path_traversal_and_jobs_are_cleaned_up(server, tmp_path):
    url, root = server
    with httpx.Client(base_url=url, timeout=60) as client:
        buf = io.BytesIO()
        Image.fromarray(np.eye(20, dtype=np.uint8) * 255).save(buf, "PNG")
        r = client.post("/jobs", files={"images": ("../../evil name.png", buf.getvalue(), "image/png")})
        job = r.headers["location"].rsplit("/", 1)[1]
        page = client.get(f"/jobs/{job}").text
        assert "evil_name.png" in page and "../" not in page.split("<tbody>")[1].split("</tbody>")[0]
        assert (root / job / "in" / "evil_name.png").is_file()
        for bad in ("..%2F..%2Fetc%2Fpasswd", "%2Fetc%2Fpasswd", "evil_name.png"):
            assert client.get(f"/jobs/{job}/files/{bad}").status_code == 404  # only outputs are served
        assert client.get("/jobs/not-a-job").status_code in (303, 307)
        client.post(f"/jobs/{job}/generate", data={"preset": "low", "formats": "stl"})
        while client.get(f"/jobs/{job}/status").json()["state"] != "done":
            time.sleep(0.2)
        assert client.get(f"/jobs/{job}/download.zip").status_code == 200
        for _ in range(100):
            if not (root / job).exists():
                break
            time.sleep(0.1)
        assert not (root / job).exists()
        assert client.get(f"/jobs/{job}/status").status_code == 404


def test_usable_at_200_percent_zoom(server, browser, fixture):
    url, _ = server
    # 200 % zoom of a 1280 px wide window leaves 640 CSS pixels: nothing may need sideways scrolling.
    context = browser.new_context(viewport={"width": 640, "height": 720}, device_scale_factor=2)
    page = context.new_page()
    page.goto(url)
    page.set_input_files("#images", str(fixture("fept_spheres_sem.png")))
    page.get_by_role("button", name="Add images").click()
    page.locator("summary").click()
    assert page.evaluate("document.documentElement.scrollWidth <= window.innerWidth + 1")
    context.close()


def test_launch_for_notebooks_serves_the_app():
    from tamp_os.gui import launch

    shown = launch()
    url = shown if isinstance(shown, str) else shown.src
    page = httpx.get(url, timeout=10)
    assert page.status_code == 200 and "Make a tactile lithograph" in page.text


def test_slicing_from_the_web_app(server):
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer")
    url, _ = server
    with httpx.Client(base_url=url, timeout=120) as client:
        buf = io.BytesIO()
        Image.fromarray((np.random.default_rng(5).random((30, 40)) * 255).astype(np.uint8)).save(buf, "PNG")
        job = client.post("/jobs", files={"images": ("p.png", buf.getvalue(), "image/png")}).headers["location"].rsplit("/", 1)[1]
        client.post(f"/jobs/{job}/generate", data={"preset": "low", "formats": "stl", "gcode": "on"})
        while client.get(f"/jobs/{job}/status").json()["state"] != "done":
            time.sleep(0.3)
        page = client.get(f"/jobs/{job}").text
        assert "Printing:" in page and "g of PLA" in page and "p.gcode" in page


def test_port_in_use_is_a_clear_message(capsys):
    import socket

    from tamp_os.cli import main

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main(["gui", "--no-browser", "--port", str(port)]) == 2
    assert "choose another port with --port" in capsys.readouterr().err


def test_per_image_override_applies_to_that_image_only(server):
    url, _ = server
    with httpx.Client(base_url=url, timeout=120) as client:
        files = []
        for i in range(2):
            buf = io.BytesIO()
            Image.fromarray((np.random.default_rng(10 + i).random((30, 40)) * 255).astype(np.uint8)).save(buf, "PNG")
            files.append(("images", (f"img{i}.png", buf.getvalue(), "image/png")))
        job = client.post("/jobs", files=files).headers["location"].rsplit("/", 1)[1]
        client.post(f"/jobs/{job}/generate", data={"preset": "low", "formats": "stl", "override_1": "high"})
        while client.get(f"/jobs/{job}/status").json()["state"] != "done":
            time.sleep(0.2)
        page = client.get(f"/jobs/{job}").text
        assert "grid 125 × 94" in page and "grid 500 × 375" in page
