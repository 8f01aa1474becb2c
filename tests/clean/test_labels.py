"""Printed text labels (clean/labels.py): a diagram's words found, removed from the relief, read
by OCR and listed by their words in the description; only confident readings are given."""

import shutil

import numpy as np
import pytest
from conftest import need
from scipy import ndimage
from synthetic_content import line_diagram

from tamp_os.clean import labels as labels_module
from tamp_os.clean import ocr
from tamp_os.clean.labels import find_labels, read_labels

WORDS = (("Nucleus", 30, 160), ("Membrane", 250, 40), ("Golgi", 360, 250))  # (word, x, y) on a 480 x 320 diagram


def _need_ocr():
    need(ocr.backend() is not None, "OCR (tesserocr with the eng model, or the tesseract command)")


def diagram_with_words(size: int = 18):
    """A diagram (a box, a circle, a joining line; strokes 3 px, black on white) with WORDS in
    Pillow's default font `size` px high; the picture and the words' pixels."""
    from PIL import Image, ImageDraw, ImageFont

    picture = Image.new("L", (480, 320), 255)
    draw = ImageDraw.Draw(picture)
    draw.rectangle([20, 60, 200, 140], outline=0, width=3)
    draw.ellipse([260, 80, 440, 180], outline=0, width=3)
    draw.line([200, 100, 260, 130], fill=0, width=3)
    strokes = np.asarray(picture) < 128
    text = Image.new("L", (480, 320), 255)
    font = ImageFont.load_default(size=size)
    for word, x, y in WORDS:
        ImageDraw.Draw(text).text((x, y), word, fill=0, font=font)
        draw.text((x, y), word, fill=0, font=font)
    return np.asarray(picture, np.float32) / 255.0, (np.asarray(text) < 128) & ~strokes


@pytest.mark.timeout(120)
def test_the_words_of_a_diagram_are_found_apart_from_its_strokes_and_read_exactly():
    _need_ocr()
    image, text = diagram_with_words()
    mask, found = find_labels(image)
    assert len(found) == len(WORDS)
    assert mask[text].mean() == 1.0  # every letter removed
    strokes = (image < 0.5) & ~ndimage.binary_dilation(text, iterations=2)
    assert not mask[strokes].any()  # no stroke of the drawing
    read = sorted((a.text, a.cols[0]) for a in read_labels(image, found))
    assert [t for t, _ in read] == sorted(w for w, _, _ in WORDS)


@pytest.mark.timeout(120)
def test_the_small_bitmap_words_of_the_content_diagram_are_read():
    _need_ocr()
    truth = line_diagram()
    mask, found = find_labels(truth.image)
    assert mask[truth.text].mean() == 1.0 and not mask[truth.lines & ~ndimage.binary_dilation(truth.text)].any()
    assert sorted(a.text for a in read_labels(truth.image, found)) == ["cell A", "link", "nucleus"]


@pytest.mark.timeout(120)
def test_the_tesseract_command_reads_the_words_when_tesserocr_is_missing(monkeypatch):
    need(shutil.which("tesseract") is not None, "the tesseract command (tesseract-ocr)")
    image, _ = diagram_with_words()
    _, found = find_labels(image)
    monkeypatch.setattr(ocr, "_api", lambda: None)
    assert sorted(a.text for a in read_labels(image, found)) == sorted(w for w, _, _ in WORDS)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("confidence, expected", [(40.0, ""), (90.0, "Nucleus")])
def test_only_a_confident_reading_is_given_as_text(monkeypatch, confidence, expected):
    image, _ = diagram_with_words()
    _, found = find_labels(image)
    monkeypatch.setattr(ocr, "read_line", lambda _image: ("Nucleus", confidence))
    assert {a.text for a in read_labels(image, found)} == {expected}


@pytest.mark.timeout(60)
def test_solid_blobs_in_a_row_and_pictures_without_paper_have_no_labels():
    """Cells or beads side by side on a bright ground are solid, not strokes; a micrograph with
    no empty paper is not searched at all."""
    rng = np.random.default_rng(1)
    image = np.ones((200, 300), np.float32)
    yy, xx = np.mgrid[:200, :300]
    for k in range(6):
        image[(yy - 100) ** 2 + (xx - 40 - 30 * k) ** 2 <= 9**2] = 0.1
    assert find_labels(image + 0.01 * rng.standard_normal(image.shape).astype(np.float32))[1] == []
    texture = rng.random((200, 300)).astype(np.float32)
    assert not labels_module.on_paper(texture) and find_labels(texture)[1] == []


@pytest.mark.timeout(60)
def test_letter_like_marks_inside_a_textured_stain_are_not_labels():
    """A brightfield slide is mostly empty paper too, but its marks sit in mid-grey tissue: the
    same word drawn inside a textured patch is left to the picture, the words on paper are found."""
    image, _ = diagram_with_words()
    rng = np.random.default_rng(3)
    stained = image.copy()
    patch = (slice(230, 300), slice(330, 470))  # around "Golgi"
    texture = 0.55 + 0.2 * ndimage.gaussian_filter(rng.standard_normal((70, 140)), 1.5).astype(np.float32)
    stained[patch] = np.where(image[patch] < 0.5, image[patch], texture)
    found = find_labels(stained)[1]
    assert len(found) == len(WORDS) - 1
    assert not any(a.rows[0] >= 230 and a.cols[0] >= 330 for a in found)


@pytest.mark.timeout(180)
def test_through_the_pipeline_the_words_leave_the_relief_and_the_description_names_them(monkeypatch):
    _need_ocr()
    from tamp_os import make_lithograph
    from tamp_os.lithograph.report import describe

    image, text = diagram_with_words()
    litho = make_lithograph(image, scale_bar="off")
    words = [a.text for a in litho.report.annotations if a.kind == "text"]
    assert sorted(words) == sorted(w for w, _, _ in WORDS)
    said = describe(litho.report, litho.params, "diagram.png")
    for part in ("'Nucleus' (left)", "'Membrane' (top centre)", "'Golgi' (bottom right)"):
        assert part in said, said
    h = litho.heightmap - litho.params.base_mm
    from skimage.transform import resize

    letters = resize(text.astype(float), h.shape, order=0) > 0.5
    assert np.percentile(h[letters], 90) < 0.5  # not raised (lines nearby may reach a few letters' edges)


@pytest.mark.timeout(120)
def test_a_picture_without_labels_reads_nothing(monkeypatch):
    """No OCR for a picture without text labels: the conversion of a micrograph pays nothing."""
    from tamp_os import make_lithograph
    from tamp_os.clean import stage

    def refuse(*_args):
        raise AssertionError("OCR asked for a picture without labels")

    monkeypatch.setattr(stage, "read_labels", refuse)
    rng = np.random.default_rng(2)
    beads = ndimage.gaussian_filter((rng.random((180, 240)) > 0.995).astype(np.float32), 3)
    litho = make_lithograph(beads / beads.max(), scale_bar="off")
    assert not [a for a in litho.report.annotations if a.kind == "text"]
