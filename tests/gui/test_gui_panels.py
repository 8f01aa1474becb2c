"""Issue 23.4 / 24.3: the web app shows the panels it found in a figure, with thumbnails, and lets the
user choose which to print, per image. Fast tests of the form parsing and the worker's detection;
then the whole flow served for real, by keyboard in headless Chromium with axe."""

from __future__ import annotations

import io
import re
import shutil
import zipfile

import httpx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from conftest import need, examples
from figures import grid_white_boxes, save, synthetic_texture
from gui_support import audit, browser, form_token, png_bytes, screenshot, start_server, stop_server, tab_to  # noqa: F401 (fixture)
from tamp_os.clean.panels import Panel, PanelLayout
from tamp_os.gui.panel_choice import (PANEL_THUMB_PX, PanelFound, checkbox_id, choice_errors, chosen_panels, find_panels,
                                      global_panel_error, panel_parameter, readme_note)
from tamp_os.gui.uploads import Upload


class Form(dict):
    """A submitted form as Starlette gives it: one value per name, or several (checkboxes)."""

    def get(self, name, default=None):
        value = super().get(name, default)
        return value[0] if isinstance(value, list) else value

    def getlist(self, name):
        value = super().get(name, [])
        return value if isinstance(value, list) else [value]


FOUND = tuple(PanelFound(label, where, (i * 10, 0, 10, 10), f"0.panel-{label}.png")
              for i, (label, where) in enumerate(zip("abcd", ("top left", "top right", "bottom left", "bottom right"))))


def _figure():
    """A 2×2 figure of synthetic micrographs on white, letters a–d in white boxes (tests/figures.py)."""
    return grid_white_boxes([synthetic_texture(150, 200, s) for s in range(4)], cols=2, gutter=14, size=22)


# ---------------------------------------------------------------------------------------------
# The form, fast


@pytest.mark.timeout(10)
def test_ticked_panels_are_read_in_the_figures_order_and_only_when_shown():
    assert chosen_panels(Form(panels_shown_0="1", panel_0=["d", "a"]), 0, FOUND) == ("a", "d")
    assert chosen_panels(Form(panels_shown_0="1"), 0, FOUND) == ()  # the checkboxes were shown, none ticked
    assert chosen_panels(Form(panel_0=["a"]), 0, FOUND) is None  # no checkboxes on that form: every panel
    assert chosen_panels(Form(panels_shown_1="1", panel_1=["a"]), 0, FOUND) is None  # another image's choice
    assert chosen_panels(Form(panels_shown_0="1", panel_0=["z", "b"]), 0, FOUND) == ("b",)  # no such panel: ignored
    assert chosen_panels(Form(panels_shown_0="1", panel_0=["a"]), 0, ()) is None  # a single picture


@pytest.mark.timeout(10)
def test_panel_parameter_is_none_for_every_panel_and_the_labels_otherwise():
    assert panel_parameter(FOUND, None) is None
    assert panel_parameter(FOUND, ("a", "b", "c", "d")) is None
    assert panel_parameter(FOUND, ("b", "d")) == "b,d"
    assert panel_parameter((), ("a",)) is None


@pytest.mark.timeout(10)
def test_a_panel_too_small_to_print_on_its_own_is_said_so():
    from tamp_os.lithograph.figure import MIN_PANEL_PX

    assert PanelFound("a", "left", (0, 0, MIN_PANEL_PX, 300), "t.png").printable
    assert not PanelFound("b", "right", (0, 0, 300, MIN_PANEL_PX - 1), "t.png").printable


@settings(max_examples=examples(60), deadline=None)
@given(st.lists(st.booleans(), min_size=4, max_size=4))
def test_what_is_ticked_is_what_make_figure_prints(ticks):
    """The checkboxes' parameter, given to the figure's own panel choice (figure._chosen), picks
    exactly the ticked panels, or every panel when all are ticked."""
    from tamp_os.lithograph.figure import _chosen
    from tamp_os.params import LithoParams

    layout = PanelLayout(True, tuple(Panel(p.box_px, p.label, True) for p in FOUND), ((0, 1), (2, 3)))
    form = Form(panels_shown_0="1", panel_0=[p.label for p, t in zip(FOUND, ticks) if t])
    chosen = chosen_panels(form, 0, FOUND)
    if not any(ticks):
        assert chosen == ()
        return
    printed = [p.label for p in _chosen(layout, LithoParams(panel=panel_parameter(FOUND, chosen)))]
    assert printed == [p.label for p, t in zip(FOUND, ticks) if t]


@pytest.mark.timeout(10)
def test_no_panel_ticked_is_an_error_linked_to_the_first_checkbox_only_with_auto():
    figure = Upload("fig.png", None, 1, 1, "low", "", panels=FOUND, panel_choice=())
    single = Upload("one.png", None, 1, 1, "low", "", panel_choice=None)
    errors = choice_errors([single, figure], "auto")
    assert list(errors) == [checkbox_id(1, "a")] == ["panel_1_a"]
    assert "Panels found in fig.png" in errors["panel_1_a"] and "tick at least one panel" in errors["panel_1_a"]
    assert choice_errors([single, figure], "off") == {} and choice_errors([single, figure], "2x2") == {}
    assert choice_errors([Upload("fig.png", None, 1, 1, "low", "", panels=FOUND, panel_choice=("a",))], "auto") == {}


@pytest.mark.timeout(10)
def test_panels_to_print_applies_only_with_a_grid():
    assert "only with a grid" in global_panel_error("auto", "b,c")["panel"]
    assert "panel" in global_panel_error("off", "b")
    assert global_panel_error("2x2", "1,3") == {} and global_panel_error("auto", "") == {}
    assert "panel_" not in global_panel_error("auto", "b")["panel"]  # the field's label, not the parameter's name


@pytest.mark.timeout(10)
def test_readme_says_which_files_are_the_overview_and_which_each_panel():
    from tamp_os.gui.jobs import readme_text

    names = ["fig.overview.stl", "fig.panel-b.stl", "fig.pages.pdf", "fig.tamp.json", "fig.overview.tamp.json", "one.stl", "one.tamp.json"]
    text = readme_text(names, {"fig.panel-b": "top right"})
    lines = dict(line.split(": ", 1) for line in text.splitlines() if line.startswith(tuple(names)))
    assert "the figure's overview" in lines["fig.overview.stl"] and lines["fig.overview.stl"].startswith("for any slicer")
    assert "panel b of the figure, top right, on its own plate" in lines["fig.panel-b.stl"]
    assert "every page of the figure, the overview first" in lines["fig.pages.pdf"]
    assert "the whole figure's recipe" in lines["fig.tamp.json"]
    assert "figure" not in lines["one.stl"] and "figure" not in lines["one.tamp.json"]
    assert readme_note("one.panel.stl", {}) == ""


@pytest.mark.timeout(60)
def test_the_worker_finds_a_figures_panels_with_a_small_thumbnail_each(tmp_path):
    need(shutil.which("tesseract") is not None, "the tesseract command (tesseract-ocr)")
    figure = _figure()
    values = figure.image.astype(np.float32) / 255
    found = find_panels(values, tmp_path, 3)
    assert [(p.label, p.where) for p in found] == [("a", "top left"), ("b", "top right"), ("c", "bottom left"), ("d", "bottom right")]
    # what each shows, as the overview says it (relief/content_word.py on the same pixels)
    from tamp_os.lithograph.content_word import content_word

    assert [p.content for p in found] == [content_word(values[y:y + h, x:x + w]).words for x, y, w, h in (p.box_px for p in found)]
    assert all(p.content for p in found)
    for p, truth in zip(found, figure.boxes):
        assert max(abs(f - t) for f, t in zip(p.box_px, truth)) <= 0.02 * truth[2]
        with Image.open(tmp_path / p.thumb) as thumb:
            assert p.thumb == f"3.panel-{p.label}.png" and max(thumb.size) <= PANEL_THUMB_PX and min(thumb.size) > 20
    single = synthetic_texture(300, 400, 7).astype(np.float32) / 255
    assert find_panels(single, tmp_path / "none", 4) == ()  # a single picture: nothing to choose, nothing written


# ---------------------------------------------------------------------------------------------
# Served for real


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    need(shutil.which("tesseract") is not None, "the tesseract command (tesseract-ocr)")
    proc, url = start_server(tmp_path_factory.mktemp("gui-panels"), slow_s=0.0)
    yield url
    stop_server(proc)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    folder = tmp_path_factory.mktemp("panel-images")
    figure = save(_figure(), folder)  # grid_white.png
    single = folder / "single.png"
    single.write_bytes(png_bytes((60, 80), 11))
    return figure, single


@pytest.mark.timeout(120)
def test_off_or_a_grid_is_not_contradicted_by_the_checkboxes(server, images):
    figure, single = images
    with httpx.Client(base_url=server, timeout=60) as client:
        token = form_token(client)
        r = client.post("/jobs", data={"token": token}, files=[("images", (p.name, p.read_bytes(), "image/png")) for p in images])
        job = r.headers["location"]
        base = {"token": form_token(client, job), "preset": "low", "formats": "stl", "panels_shown_0": "1", "action": "update"}
        off = client.post(f"{job}/generate", data={**base, "panels": "off"})  # none ticked, but off: no error
        assert off.status_code == 200 and "error-summary" not in off.text
        assert "“Panels of a figure” is off, so these choices do not apply" in off.text
        auto = client.post(f"{job}/generate", data={**base, "panel_0": ["a"], "panels": "auto", "panel": "b"})
        assert auto.status_code == 400 and 'href="#panel"' in auto.text and "only with a grid" in auto.text
        kept = re.search(r'<input type="checkbox" id="panel_0_a"[^>]*>', auto.text).group(0)
        assert "checked" in kept and "checked" not in re.search(r'<input type="checkbox" id="panel_0_b"[^>]*>', auto.text).group(0)


def _space_toggles(page, box_id: str) -> None:
    tab_to(page, lambda i: i["id"] == box_id)
    before = page.is_checked(f"#{box_id}")
    page.keyboard.press("Space")
    assert page.is_checked(f"#{box_id}") != before
    assert page.evaluate("document.activeElement.id") == box_id  # focus stays on the checkbox


@pytest.mark.timeout(420)
def test_choose_a_figures_panels_by_keyboard_and_get_only_those(server, browser, images):
    from playwright.sync_api import TimeoutError as PlaywrightTimeout

    page = browser.new_context(accept_downloads=True).new_page()
    page.goto(server)
    tab_to(page, lambda i: i["id"] == "images")
    for attempt in range(3):  # see test_gui.py: the first key press after load is now and then lost
        try:
            with page.expect_file_chooser(timeout=5000) as chooser:
                page.keyboard.press("Space")
            break
        except PlaywrightTimeout:
            assert attempt < 2, "the file chooser never opened from the keyboard"
    chooser.value.set_files([str(p) for p in images])
    tab_to(page, lambda i: i["text"] == "Add images")
    page.keyboard.press("Enter")
    page.wait_for_selector("h1:has-text('Step 2 of 3')", timeout=90000)

    # The figure shows its panels; the single picture shows nothing extra.
    fieldsets = page.locator("fieldset.panel-choices")
    assert fieldsets.count() == 1
    assert fieldsets.locator("legend").inner_text() == "Panels found in grid_white.png"
    assert "on its own plate" in fieldsets.inner_text() and "overview" in fieldsets.inner_text()
    names = ["Panel a (top left)", "Panel b (top right)", "Panel c (bottom left)", "Panel d (bottom right)"]
    for label, name in zip("abcd", names):
        box = page.get_by_role("checkbox", name=name, exact=True)
        assert box.count() == 1 and box.is_checked() and box.get_attribute("id") == f"panel_0_{label}"
        shows = page.locator(f"#{box.get_attribute('aria-describedby')}").inner_text()  # what it shows, its description
        assert shows.startswith("Shows: ") and len(shows) > len("Shows: ")
    thumbs = fieldsets.locator("img")
    assert thumbs.count() == 4
    page.wait_for_function("[...document.querySelectorAll('fieldset.panel-choices img')].every(i => i.complete)", timeout=30000)
    for k in range(4):  # inside the label, which says it: empty alt, so it is heard once; and it loaded
        assert thumbs.nth(k).get_attribute("alt") == ""
        assert 20 < page.evaluate(f"document.querySelectorAll('fieldset.panel-choices img')[{k}].naturalWidth") <= 120
    single = page.locator("li.upload").nth(1)
    assert "single.png" in single.inner_text() and single.locator("fieldset, input[type=checkbox]").count() == 0
    audit(page, "settings with a figure's panels")
    screenshot(page, "panels-1-settings")

    # None ticked: one error in the summary, which takes the focus and links to the first checkbox.
    for label in "abcd":
        _space_toggles(page, f"panel_0_{label}")
    tab_to(page, lambda i: i["text"] == "Generate")
    with page.expect_navigation():
        page.keyboard.press("Enter")
    assert page.title().startswith("Error:")
    assert page.evaluate("document.activeElement.id") == "error-summary"
    links = page.locator("#error-summary a")
    assert links.count() == 1 and links.get_attribute("href") == "#panel_0_a" and "tick at least one panel" in links.inner_text()
    assert page.locator("#panels_0-error").count() == 1 and "panels_0-error" in page.get_attribute("#panels_0", "aria-describedby")
    assert not any(page.is_checked(f"#panel_0_{label}") for label in "abcd")  # the page keeps what was ticked
    audit(page, "settings with no panel ticked")
    screenshot(page, "panels-2-error")

    # Tick a, b and d again (c stays off), by keyboard, and generate.
    for label in "abd":
        _space_toggles(page, f"panel_0_{label}")
    assert [page.is_checked(f"#panel_0_{label}") for label in "abcd"] == [True, True, False, True]
    tab_to(page, lambda i: i["text"] == "Generate")
    page.keyboard.press("Enter")
    page.wait_for_selector("h1:has-text('Your lithographs')", timeout=300000)
    page.wait_for_timeout(500)  # the focus move to the results heading
    assert page.evaluate("document.activeElement.id") == "page-title"

    figure = page.locator("section.result").nth(0)
    headings = figure.locator("h3").all_inner_texts()
    assert headings[:4] == ["Overview of the layout", "Panel a (top left)", "Panel b (top right)", "Panel d (bottom right)"], headings
    assert "Panel c (bottom left)" not in headings and "Panel c was not chosen" in figure.inner_text()
    assert page.locator("#description-1").inner_text().startswith("Overview of the figure grid_white.png")
    for label in "abd":
        description = page.locator(f"#description-1-panel-{label}").inner_text()
        assert description.startswith(f"Panel {label} of four in the figure grid_white.png")
        assert figure.inner_text().count(description) == 1  # each description read once
        files = page.locator(f"ul[aria-labelledby='print-1-panel-{label}'] li").all_inner_texts()
        assert any(t.startswith(f"grid_white.panel-{label}.stl") for t in files), files
    assert page.locator("section.result").nth(1).locator("h3", has_text="Overview").count() == 0  # the single picture
    audit(page, "results of a figure and a picture")
    screenshot(page, "panels-3-results")

    tab_to(page, lambda i: i["text"] == "Download everything (zip)")
    with page.expect_download(timeout=60000) as download:
        page.keyboard.press("Enter")
    with zipfile.ZipFile(download.value.path()) as z:
        names = set(z.namelist())
        readme = z.read("README.txt").decode()
        overview = z.read("grid_white.overview.stl")
    assert {"grid_white.overview.stl", "grid_white.panel-a.stl", "grid_white.panel-b.stl", "grid_white.panel-d.stl",
            "grid_white.tamp.json", "single.stl"} <= names, names
    assert not any(".panel-c." in n for n in names), names  # the panel left out has no file at all
    assert re.search(r"^grid_white\.panel-d\.stl: for any slicer.*panel d of the figure, bottom right", readme, re.M)
    assert re.search(r"^grid_white\.overview\.stl: .*the figure's overview", readme, re.M)
    import trimesh

    assert trimesh.load(io.BytesIO(overview), file_type="stl").is_watertight
    page.context.close()
