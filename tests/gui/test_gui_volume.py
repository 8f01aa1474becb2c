"""The web app and z-stacks: "Print as a 3-D model" is offered for an upload with a z axis, is a
labelled checkbox, and makes a closed 3-D model of the stack while a flat picture beside it stays a relief."""

from __future__ import annotations

import io
import re
import zipfile

import httpx
import numpy as np
import pytest
import tifffile
import trimesh

from gui_support import audit, browser, generate_and_wait, new_job, png_bytes, start_server, stop_server, tab_to  # noqa: F401 (fixture)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    proc, url = start_server(tmp_path_factory.mktemp("gui-volume"), slow_s=0.0)
    yield url
    stop_server(proc)


def ball_stack() -> bytes:
    """An ImageJ z-stack of a ball, 24 slices, its voxel size known."""
    z, y, x = np.mgrid[:24, :24, :24]
    ball = np.where(np.sqrt((x - 12) ** 2 + (y - 12) ** 2 + (z - 12) ** 2) < 8, 1000, 100).astype(np.uint16)
    buf = io.BytesIO()
    tifffile.imwrite(buf, ball, imagej=True, resolution=(2.0, 2.0), metadata={"spacing": 0.5, "unit": "um", "axes": "ZYX"})
    return buf.getvalue()


@pytest.mark.timeout(300)
def test_a_z_stack_is_offered_and_printed_as_a_3d_model(server):
    with httpx.Client(base_url=server, timeout=120, follow_redirects=False) as client:
        flat_only = new_job(client, [("flat.png", png_bytes((30, 40)))])
        assert 'id="volume"' not in client.get(f"/jobs/{flat_only}").text  # no z axis: not offered
        job = new_job(client, [("ball.tif", ball_stack()), ("flat.png", png_bytes((30, 40)))])
        page = client.get(f"/jobs/{job}").text
        box = re.search(r'<input id="volume" name="volume" type="checkbox"[^>]*>', page).group(0)
        assert "checked" not in box and 'aria-describedby="volume-help"' in box  # off unless asked; its help tied to it
        assert '<label for="volume">Print as a 3-D model</label>' in page
        generate_and_wait(client, job, volume="on", formats=["stl", "pdf"])
        results = client.get(f"/jobs/{job}").text
        assert "3-D tactile model of" in results and "Rendered picture of the 3-D model of ball.tif" in results
        assert "ball.heightmap.png" not in results and "flat.heightmap.png" in results  # the flat picture stays a relief
        line = re.search(r"ball\.tif: 3-D model [^<]*", results).group(0)  # the name as uploaded, not capitalised
        assert "; wrote " in line and " to /" not in line, line  # never the server's own folder (issue 54.5)
        archive = zipfile.ZipFile(io.BytesIO(client.get(f"/jobs/{job}/download.zip").content))
        names = set(archive.namelist())
        assert {"ball.stl", "ball.description.txt", "ball.tamp.json", "flat.stl", "flat.pdf"} <= names
        assert "ball.pdf" not in names  # a model is written as meshes only
        mesh = trimesh.load(io.BytesIO(archive.read("ball.stl")), file_type="stl", process=True)
        assert mesh.is_watertight and mesh.volume > 0
        assert "3-D tactile model" in archive.read("ball.description.txt").decode()


@pytest.mark.timeout(180)
def test_the_3d_model_checkbox_is_reached_and_ticked_by_keyboard(server, browser):
    with httpx.Client(base_url=server, timeout=60, follow_redirects=False) as client:
        job = new_job(client, [("ball.tif", ball_stack())])
    page = browser.new_page()
    page.goto(f"{server}/jobs/{job}")
    audit(page, "settings of a z-stack")  # axe, WCAG 2.2 AA: the new fieldset and checkbox included
    tab_to(page, lambda i: i["id"] == "volume")  # reached by Tab, its focus visible
    assert page.evaluate("document.activeElement.labels[0].textContent") == "Print as a 3-D model"
    page.keyboard.press("Space")
    assert page.is_checked("#volume") and page.evaluate("document.activeElement.id") == "volume"
    page.close()
