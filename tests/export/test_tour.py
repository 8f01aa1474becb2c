"""The touch tour page (issue 35), in headless Chromium with every network request blocked: touching
(clicking) each region's touch point and stepping through the regions by keyboard announce that
region in the live region and through the Web Speech API; axe finds no WCAG 2.2 AA violation; the
plate is drawn at its true size in CSS millimetres."""

from __future__ import annotations

import json
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from gui_support import audit, browser  # noqa: E402,F401
from synthetic_content import dim_and_bright_beads  # noqa: E402

pytestmark = pytest.mark.timeout(240)

REAL = ("fept_spheres_sem.png", "real/zeiss_sem_al2o3_grains.czi", "real/zeiss_dapi_gfp_2ch.czi")
SPEECH_SPY = "window.__spoken = []; if (window.speechSynthesis) { window.speechSynthesis.speak = function (u) { window.__spoken.push(u.text); }; }"


@pytest.fixture(scope="module")
def beads_tour(tmp_path_factory):
    from tamp_os import make_lithograph

    litho = make_lithograph(dim_and_bright_beads().image, pixel_size="50nm", caption="ten beads", preset="low")
    folder = tmp_path_factory.mktemp("tour")
    litho.save(folder, formats=("tour",), stem="beads")
    return folder / "beads.tour.html"


def tour_data(html: str) -> list[dict]:
    return json.loads(re.search(r'<script type="application/json" id="tour-data">(.*?)</script>', html, re.S).group(1).replace("<\\/", "</"))


def test_every_tour_item_resolves_to_a_labelled_svg_element(beads_tour):
    html = beads_tour.read_text(encoding="utf-8")
    svg = ET.fromstring(html[html.index("<svg"): html.index("</svg>") + 6])
    by_id = {e.attrib["id"]: e for e in svg.iter() if "id" in e.attrib}
    items = tour_data(html)
    assert items[0]["id"] == "corner" and len(items) >= 5
    for item in items:
        element = by_id[item["id"]]
        assert element.attrib["role"] == "graphics-object" and element.attrib["aria-label"].strip() == item["label"]
        assert item["description"].strip()
    assert re.search(r'width="[\d.]+mm" height="[\d.]+mm"', html[html.index("<svg"):][:400])  # true size
    assert not re.search(r"(src|href)=\"(https?:)?//", html)  # nothing to fetch


def _open(browser, path: Path, viewport=(1280, 1100)):
    """The page from a file, every request but the file itself refused (and counted)."""
    context = browser.new_context(viewport={"width": viewport[0], "height": viewport[1]})
    blocked = []

    def route(r):
        if r.request.url.startswith("file:"):
            r.continue_()
        else:
            blocked.append(r.request.url)
            r.abort()

    context.route("**/*", route)
    page = context.new_page()
    page.add_init_script(SPEECH_SPY)
    page.goto(path.as_uri())
    return context, page, blocked


def _screen_point(page, region_id: str) -> tuple[float, float]:
    return page.evaluate("""(id) => {
        const el = document.getElementById(id);
        el.ownerSVGElement.scrollIntoView({block: 'center'});
        const svg = el.ownerSVGElement, p = svg.createSVGPoint();
        p.x = Number(el.getAttribute('data-x')); p.y = Number(el.getAttribute('data-y'));
        const q = p.matrixTransform(svg.getScreenCTM());
        return [q.x, q.y];
    }""", region_id)


def _announced(page) -> str:
    return page.locator("#announce").text_content().strip()


def read_through(page, items) -> list[str]:
    """Tab into the graphic, then Enter on each region and an arrow key to the next: what the live region said."""
    page.keyboard.press("Tab")
    assert page.evaluate("document.activeElement.id") == items[0]["id"]
    said = []
    for i, item in enumerate(items):
        page.keyboard.press("Enter")
        said.append(_announced(page))
        assert said[-1] == f"{item['label']}. {item['description']}"
        if i + 1 < len(items):
            page.keyboard.press("ArrowRight")
            assert _announced(page) == items[i + 1]["label"]
            assert page.evaluate("document.activeElement.id") == items[i + 1]["id"]
    return said


def _check_page(browser, path: Path) -> list[str]:
    items = tour_data(path.read_text(encoding="utf-8"))
    context, page, blocked = _open(browser, path)
    try:
        for item in items:  # touch each region at its touch point
            x, y = _screen_point(page, item["id"])
            page.mouse.click(x, y)
            assert _announced(page) == f"{item['label']}. {item['description']}", item["id"]
        spoken = page.evaluate("window.__spoken")
        assert spoken and spoken[-1] == f"{items[-1]['label']}. {items[-1]['description']}"
        page.reload()
        said = read_through(page, items)
        page.keyboard.press("Home")
        assert _announced(page) == items[0]["label"]
        page.keyboard.press("ArrowLeft")  # before the first: stays there
        assert page.evaluate("document.activeElement.id") == items[0]["id"]
        page.keyboard.press("End")
        assert _announced(page) == items[-1]["label"]
        # the plate at its true size: 1 CSS mm = 96 / 25.4 px at zoom 1
        width_px, width_mm = page.evaluate("""() => { const s = document.querySelector('#plate svg');
            return [s.getBoundingClientRect().width, parseFloat(s.getAttribute('width'))]; }""")
        assert abs(width_px - width_mm * 96 / 25.4) < 1.0
        audit(page, f"tour {path.name}")
        assert blocked == []  # it asked for nothing beyond its own file
    finally:
        context.close()
    return said


def test_touching_and_stepping_announce_each_region_offline(browser, beads_tour):
    said = _check_page(browser, beads_tour)
    assert said[0].startswith("orientation corner.")


def test_the_list_buttons_announce_their_region(browser, beads_tour):
    items = tour_data(beads_tour.read_text(encoding="utf-8"))
    context, page, _ = _open(browser, beads_tour)
    try:
        page.locator("#tour-list button").nth(3).click()
        assert _announced(page) == f"{items[3]['label']}. {items[3]['description']}"
        assert page.evaluate("document.activeElement.id") == items[3]["id"]
    finally:
        context.close()


@pytest.mark.real
@pytest.mark.parametrize("name", REAL)
def test_real_tours_read_through(browser, name, tmp_path, fixture):
    from tamp_os import make_lithograph

    litho = make_lithograph(fixture(name), **({"preset": "low"} if name.endswith("2ch.czi") else {}))
    litho.save(tmp_path, formats=("tour",), stem="real")
    said = _check_page(browser, tmp_path / "real.tour.html")
    assert said[0].startswith("orientation corner.") and len(said) >= 4
