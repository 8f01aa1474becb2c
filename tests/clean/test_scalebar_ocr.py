"""The scale bar's label is read once per content within a process (clean/scalebar.ocr_text):
the same strokes again, in another array, are answered from memory; other strokes are read;
a failed reading is not remembered."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from PIL import Image, ImageDraw

from conftest import need
from figures import font
from tamp_os.clean import ocr, scalebar


def _label(text: str) -> np.ndarray:
    canvas = Image.new("L", (120, 40), 255)
    ImageDraw.Draw(canvas).text((6, 2), text, fill=0, font=font(28))
    return np.asarray(canvas) < 128


@pytest.fixture
def calls(monkeypatch):
    """The crops Tesseract is asked to read (it answers with the ink count, or fails on request)."""
    asked = []

    def fake(ink):
        asked.append(ink.copy())
        return (None, False) if fake.fail else (f"{int(ink.sum())} nm\n", True)

    fake.fail = False
    monkeypatch.setattr(scalebar, "_tesseract", fake)
    monkeypatch.setattr(scalebar.ocr, "backend", lambda: "tesserocr")
    scalebar.clear_ocr_cache()
    yield asked, fake
    scalebar.clear_ocr_cache()


@pytest.mark.timeout(60)
def test_the_same_strokes_are_read_once(calls):
    asked, _ = calls
    ink = _label("5 um")
    first = scalebar.ocr_text(ink)
    again = scalebar.ocr_text(np.array(ink, copy=True))  # another array, the same content
    assert first == again == f"{int(ink.sum())} nm\n"
    assert len(asked) == 1


@pytest.mark.timeout(60)
def test_other_strokes_or_another_shape_are_read_again(calls):
    asked, _ = calls
    ink = _label("5 um")
    scalebar.ocr_text(ink)
    scalebar.ocr_text(_label("2 um"))
    padded = np.zeros((ink.shape[0], ink.shape[1] + 8), bool)
    padded[:, : ink.shape[1]] = ink  # the same strokes in a wider crop: the crop Tesseract sees differs
    scalebar.ocr_text(padded)
    assert len(asked) == 3


@pytest.mark.timeout(60)
def test_a_failed_reading_is_tried_again(calls):
    asked, fake = calls
    fake.fail = True
    ink = _label("5 um")
    assert scalebar.ocr_text(ink) is None
    fake.fail = False
    assert scalebar.ocr_text(ink) == f"{int(ink.sum())} nm\n"
    assert len(asked) == 2


@pytest.mark.timeout(120)
def test_a_label_read_from_memory_says_what_tesseract_said():
    need(ocr.backend() is not None, "OCR (tesserocr with the eng model, or the tesseract command)")
    scalebar.clear_ocr_cache()
    ink = _label("5 um")
    first = scalebar.ocr_text(ink)
    assert scalebar.ocr_text(ink.copy()) == first
    assert scalebar.parse_label(first or "") == pytest.approx(5e-6)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("text, metres", [("5 um", 5e-6), ("200 nm", 2e-7), ("2 µm", 2e-6)])
def test_the_command_reads_a_label_as_tesserocr_does(monkeypatch, text, metres):
    """In process (tesserocr) is the rule; the `tesseract` command, the fallback, reads the same length."""
    need(ocr.backend() == "tesserocr", "tesserocr with the eng model")
    need(shutil.which("tesseract") is not None, "the tesseract command (tesseract-ocr)")
    ink = _label(text)
    scalebar.clear_ocr_cache()
    in_process = scalebar.ocr_text(ink)
    monkeypatch.setattr(scalebar.ocr, "backend", lambda: "command")
    scalebar.clear_ocr_cache()
    by_command = scalebar.ocr_text(ink)
    scalebar.clear_ocr_cache()
    assert scalebar.parse_label(in_process or "") == pytest.approx(metres)
    assert scalebar.parse_label(by_command or "") == pytest.approx(metres)
