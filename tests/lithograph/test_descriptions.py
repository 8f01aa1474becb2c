"""Issue 24.4: descriptions read as alt text: subject first, then the layout in words, then scale,
caption and orientation, technical figures last; every count agrees with its verb."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tamp_os.lithograph.layout_words import count_words, find_layout, layout_sentence, place_word
from tamp_os.lithograph.outputs import metadata
from tamp_os.lithograph.pipeline import make_lithograph
from conftest import examples


def _discs(centres_px, radii_px, shape=(100, 200)):
    """Heights in mm: a 1 mm base and 3 mm tall discs (row 0 is the far edge)."""
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    h = np.ones(shape)
    for (cx, cy), r in zip(centres_px, radii_px):
        h[(xx - cx) ** 2 + (yy - cy) ** 2 < r * r] = 4.0
    return h


def test_four_bumps_across_the_middle_the_largest_at_the_right():
    h = _discs([(30, 50), (80, 50), (130, 50), (175, 50)], [8, 8, 8, 14])
    layout = find_layout(h, 0.5, base_mm=1.0, relief_mm=3.0)
    assert len(layout.pieces) == 4 and layout.pieces[0].place == "right"
    assert all(p.shape == "round" for p in layout.pieces)
    assert layout.pieces[0].area_mm2 == pytest.approx(np.pi * 14**2 * 0.25, rel=0.05)
    assert layout_sentence(layout, "bump") == "Four round bumps stand up across the middle, the largest at the right."


def test_one_shape_and_its_place_from_the_far_edge():
    h = _discs([(170, 15)], [10])  # near the far (top) edge, at the right
    sentence = layout_sentence(find_layout(h, 0.5, 1.0, relief_mm=3.0))
    assert sentence == "One round raised shape stands up at the top right."


def test_specks_smaller_than_a_fingertip_are_not_counted():
    h = _discs([(20, 20), (100, 50)], [1, 12])  # a 1-px-radius speck (0.8 mm²) and a disc
    assert len(find_layout(h, 0.5, 1.0, relief_mm=3.0).pieces) == 1


@pytest.mark.parametrize("x, y, word", [(0.1, 0.1, "top left"), (0.5, 0.1, "top"), (0.5, 0.5, "centre"),
                                         (0.9, 0.5, "right"), (0.2, 0.9, "bottom left"), (0.5, 0.95, "bottom")])
def test_place_words(x, y, word):
    assert place_word(x, y) == word


@settings(max_examples=examples(80), deadline=None)
@given(n=st.integers(0, 30))
def test_counts_agree(n):
    text = count_words(n, "object")
    assert text.endswith("object") == (n == 1)
    assert text.split()[0] == ("one" if n == 1 else text.split()[0])


@settings(max_examples=examples(25), deadline=None)
@given(count=st.integers(1, 7), seed=st.integers(0, 10_000))
def test_layout_sentence_grammar_for_any_count(count, seed):
    rng = np.random.default_rng(seed)
    xs = rng.choice(np.arange(12, 190, 26), size=count, replace=False)
    h = _discs([(int(x), int(rng.integers(15, 85))) for x in xs], [8] * count)
    layout = find_layout(h, 0.5, 1.0, relief_mm=3.0)
    sentence = layout_sentence(layout)
    n = len(layout.pieces)
    assert n == count
    assert (" stands up " in sentence) == (n == 1) and (" stand up " in sentence) == (n != 1)
    assert not re.search(r"\b1 \w+s\b|\bone \w+s stand\b", sentence)


@pytest.mark.timeout(300)
def test_description_order_subject_layout_scale_caption_orientation_then_figures():
    img = np.zeros((60, 90))
    img[20:40, 60:80] = 1.0  # one block at the right
    litho = make_lithograph(img, width_mm=90, subject="a single cell", caption="cell", pixel_size="1um")
    text = metadata(litho)["description"]
    assert text.startswith("A tactile print of a single cell.")
    order = [text.index(s) for s in ("a single cell", "stands up at the right", "Scale:", "braille caption", "corner", "mm wide", "What a finger will find")]
    assert order == sorted(order), text
    assert "array" not in text.split(".")[0]  # the subject, not the file name, opens it


@pytest.mark.timeout(300)
def test_without_a_subject_the_kind_of_image_comes_from_the_metadata(fixture):
    litho = make_lithograph(fixture("test_tiff_Zeiss_SEM_1k.tif"), preset="low")
    text = metadata(litho)["description"]
    assert text.startswith("A tactile print of a scanning electron microscope (SEM) image made with secondary electrons")


@pytest.mark.timeout(300)
def test_one_object_stands():
    yy, xx = np.mgrid[0:80, 0:80]
    img = ((xx - 40) ** 2 + (yy - 40) ** 2 < 15**2).astype(float)
    litho = make_lithograph(img, width_mm=60, relief_style="objects")
    text = metadata(litho)["description"]
    assert litho.report.legibility["object_count"] == 1
    assert "One object found in the picture stands up" in text
    assert not re.search(r"\b1 object stand\b|\bone object stand\b", text)


@pytest.mark.timeout(120)
def test_content_prints_say_what_they_raise_not_brightness():
    """A dark line network raised as lines must not be described as 'the bright parts raised' or
    as texture with nothing to find; a population says domes by the same lift, and the members'
    count is said once (the content check), not again by a second, different measure."""
    from synthetic_content import dark_line_network, dim_and_bright_beads

    from tamp_os.lithograph.report import describe

    lines = make_lithograph(dark_line_network().image, width_mm=100, relief_style="content")
    assert lines.report.content_kind == "lines" and lines.report.as_dict()["content_kind"] == "lines"
    text = describe(lines.report, lines.params, "lines.png")
    assert "raised lines about 1 mm high" in text and "areas they enclose stay low" in text
    assert "bright parts" not in text and "felt as texture" not in text

    beads = make_lithograph(dim_and_bright_beads().image, width_mm=100, relief_style="content")
    text = describe(beads.report, beads.params, "beads.png")
    assert beads.report.content_kind == "members"
    assert "dome by the same lift" in text and "bright parts" not in text
    assert len(re.findall(r"Found \d+ members?", text)) == 1 and "objects stand" not in text

    plain = make_lithograph(dark_line_network().image, width_mm=100, relief_style="structure")
    assert plain.report.content_kind == "" and "content_kind" not in plain.report.as_dict()
