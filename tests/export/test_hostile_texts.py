"""Hostile texts in the touch tour and the eBraille package (issue 51.3): captions, key labels and
file names holding control characters, bidirectional marks, entities, `]]>`, `<!--`, `<script`,
markup with event handlers, line and paragraph separators and 10,000 characters. The tour stays
one page whose data script and program script both run (in headless Chromium: every region
touched and stepped through says exactly its text, nothing the texts hold runs); the eBraille
package conforms (tests/ebraille_check.py, EPUBCheck) and holds no executable content."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
import xml.etree.ElementTree as ET
from html.parser import HTMLParser

import numpy as np
import pytest
from PIL import Image

from cli_support import run_cli_child
from conftest import need
from ebraille_check import check_bytes, read_zip
from gui_support import browser  # noqa: F401
from synthetic_content import dim_and_bright_beads, fluorescence_composite
from test_ebraille import _assert_epubcheck_clean
from test_tour import _check_page, _open, tour_data

pytestmark = pytest.mark.timeout(300)

HOSTILE = {
    "control": "ctl \x00\x01\x07\x08\x0b\x0c\x1b[31mred\x1b[0m \x7f\x85 end",
    "bidi": "\u202eevil\u202c \u200f\u2066rtl\u2069 zero\u200bwidth",
    "entities": "&amp; &lt;b&gt; &#60; &#x3c; &nbsp; &bogus;",
    "cdata": "]]> ]]&gt; <![CDATA[ x ]]>",
    "comment": "<!--<script>",
    "script": "</script><script>window.__pwned = 1</script>",
    "markup": '<img src=x onerror="window.__pwned = 2"><svg onload="window.__pwned = 3">',
    "quotes": "'\"` \\u003c \\",
    "separators": "line\u2028para\u2029end",
    "undecodable": "name\udcff\udcfe.png",  # a file name's bytes that are not UTF-8
    "long": "long " + "x" * 10_000,
}


@pytest.fixture(scope="module")
def beads():
    from tamp_os import make_lithograph
    from tamp_os.export.regions import tour_from_lithograph
    from tamp_os.lithograph.outputs import tactile_graphic

    litho = make_lithograph(dim_and_bright_beads().image, pixel_size="50nm", caption="ten beads", preset="low")
    graphic = tactile_graphic(litho)
    return litho, graphic, tour_from_lithograph(litho, graphic)


def hostile_tour(tour):
    """The tour with every region's label and description a hostile text (each text on several regions)."""
    texts = list(HOSTILE.values())
    regions = tuple(dataclasses.replace(r, label=f"{texts[i % len(texts)]} {i}", description=texts[(i + 3) % len(texts)])
                    for i, r in enumerate(tour.regions))
    return dataclasses.replace(tour, title=" | ".join(texts[:-1]), regions=regions)


class StartTags(HTMLParser):
    """Every start tag an HTML parser finds, with its attributes."""

    def __init__(self):
        super().__init__()
        self.seen: list[tuple[str, list]] = []

    def handle_starttag(self, tag, attrs):
        self.seen.append((tag, attrs))


def _script_data(html: str) -> str:
    return re.search(r'<script type="application/json" id="tour-data">(.*?)</script>', html, re.S).group(1)


@pytest.mark.timeout(120)
def test_the_tour_data_hides_every_text_from_the_html_parser(beads):
    from tamp_os.export.tour import tour_page

    _, graphic, tour = beads
    tour = hostile_tour(tour)
    html = tour_page(tour, graphic)
    html.encode("utf-8")  # every character can be written (no lone surrogate)
    data = _script_data(html)
    assert not set(data) & set("<>&\u2028\u2029"), "a character the HTML parser or old JavaScript reads"
    items = json.loads(data)
    assert [i["label"] for i in items] == [r.label.replace("\udcff", "\ufffd").replace("\udcfe", "\ufffd") for r in tour.regions]
    tags = StartTags()
    tags.feed(html)
    assert [t for t, _ in tags.seen].count("script") == 2  # the data and the program, nothing else
    assert not [t for t, _ in tags.seen if t in ("img", "iframe", "object", "embed", "foreignobject")]
    assert not [(t, a) for t, attrs in tags.seen for a, _ in attrs if a.startswith("on")]  # the markup is only text


@pytest.mark.timeout(240)
def test_a_hostile_tour_page_is_intact_in_chromium(browser, beads, tmp_path):
    from tamp_os.export.tour import tour_page

    _, graphic, tour = beads
    tour = hostile_tour(tour)
    path = tmp_path / "hostile.tour.html"
    path.write_text(tour_page(tour, graphic), encoding="utf-8")
    items = tour_data(path.read_text(encoding="utf-8"))
    said = _check_page(browser, path)  # each region touched and stepped through says its own label and description
    assert len(said) == len(tour.regions) and said[0].startswith(items[0]["label"])
    context, page, _ = _open(browser, path)
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        page.reload()
        page.keyboard.press("Tab")
        page.keyboard.press("End")
        got = page.evaluate("""() => ({
            scripts: document.scripts.length,
            data: JSON.parse(document.getElementById('tour-data').textContent),
            handlers: [...document.querySelectorAll('*')].filter(e => [...e.attributes].some(a => a.name.startsWith('on'))).length,
            foreign: document.querySelectorAll('img, iframe, object, embed, foreignObject, svg svg').length,
            pwned: window.__pwned === undefined ? null : window.__pwned,
            buttons: document.querySelectorAll('#tour-list button').length,
        })""")
    finally:
        context.close()
    assert got["data"] == items and got["buttons"] == len(items)
    assert (got["scripts"], got["handlers"], got["foreign"], got["pwned"]) == (2, 0, 0, None), got
    assert errors == []


def _hostile_book(litho, graphic, tour):
    from tamp_os.export.ebraille import Book

    texts = list(HOSTILE.values())
    return Book(title=" | ".join(texts), caption=HOSTILE["comment"] + HOSTILE["cdata"], description=" ".join(texts),
                key=tuple((t, texts[(i + 1) % len(texts)]) for i, t in enumerate(texts)), tour=hostile_tour(tour),
                braille_table=litho.params.braille_table, identifier_seed="hostile", producer=HOSTILE["markup"],
                source_name=HOSTILE["undecodable"])


@pytest.mark.timeout(240)
def test_a_hostile_ebraille_package_conforms_and_runs_nothing(beads, tmp_path):
    from tamp_os.export.ebraille import package_files, zip_bytes

    litho, graphic, tour = beads
    files, _ = package_files(_hostile_book(litho, graphic, tour), graphic, litho.picture.values)
    data = zip_bytes(files)
    assert check_bytes(data, "hostile.ebrl") == []  # EBR-040 among them: no script element, no on* attribute
    for name in ("package.opf", "index.html", "content.html"):
        root = ET.fromstring(files[name])  # well-formed XML, whatever the texts held
        assert not [e for e in root.iter() if e.tag.rsplit("}", 1)[-1] in ("script", "img", "iframe", "embed")
                    and e.attrib.get("src") != "micrograph.png"], name
        assert not [k for e in root.iter() for k in e.attrib if k.lower().startswith("on")], name
    title = ET.fromstring(files["package.opf"]).find(".//{http://purl.org/dc/elements/1.1/}title").text
    assert HOSTILE["comment"] in title and HOSTILE["cdata"] in title  # said as text, not dropped
    need(shutil.which("epubcheck") is not None and shutil.which("java") is not None, "epubcheck (apt-get install epubcheck)")
    _assert_epubcheck_clean(data, tmp_path)


@pytest.mark.timeout(300)
def test_a_hostile_caption_key_label_and_file_name_through_the_command_line(browser, tmp_path):
    """The whole way: a channel picture named with `<!--<script>`, its caption and a key label too."""
    name = "<!--<script> & ]]> x.png"
    Image.fromarray(fluorescence_composite()).save(tmp_path / name)
    out = tmp_path / "out"
    code, err, _, _, _ = run_cli_child("convert", tmp_path / name, "-o", out, "--formats", "tour,ebraille", "--preset", "low",
                                       "--caption", "<!--<script> a & b", "--key-labels", "blue=<!--<script>nuclei", timeout_s=240)
    assert code == 0 and "Traceback" not in err and "error:" not in err, err
    tour_path = out / "<!--<script> & ]]> x.tour.html"
    items = tour_data(tour_path.read_text(encoding="utf-8"))
    labels = [i["label"] for i in items]
    assert "key: <!--<script>nuclei" in labels and any("<!--<script>nuclei" in i["description"] for i in items), labels
    assert any("<!--<script> a & b" in i["description"] for i in items)  # the caption's region
    _check_page(browser, tour_path)
    package = (out / "<!--<script> & ]]> x.ebrl").read_bytes()
    assert check_bytes(package, "x.ebrl") == []
    files, _ = read_zip(package)
    assert "<!--<script>" in ET.fromstring(files["package.opf"]).find(".//{http://purl.org/dc/elements/1.1/}title").text
