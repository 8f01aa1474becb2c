"""A pixel size from a scale bar burned into the image, used only when the file records none.

The bar's length comes from annotation detection; its label ("10 µm") is read with the
Tesseract OCR command when it is installed. Only a label that reads cleanly as exactly one
number and a length unit is used: a misread scale is worse than none.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from ..units import unit_factor_m

LABEL = re.compile(r"^\s*([0-9]+(?:[.,][0-9]+)?)\s*(nm|µm|μm|um|mm)\s*$")


def ocr_text(image: np.ndarray) -> str | None:
    """Text in a small grayscale crop, by the `tesseract` command (None when not installed)."""
    exe = shutil.which("tesseract")
    if exe is None:
        return None
    from PIL import Image

    lo, hi = float(image.min()), float(image.max())
    scaled = ((image - lo) / (hi - lo or 1) * 255).astype(np.uint8)
    if scaled.mean() < 128:  # OCR prefers dark text on a light ground
        scaled = 255 - scaled
    picture = Image.fromarray(scaled).resize((scaled.shape[1] * 3, scaled.shape[0] * 3), Image.Resampling.LANCZOS)
    with tempfile.TemporaryDirectory(prefix="tamp-ocr-") as tmp:
        path = Path(tmp) / "label.png"
        picture.save(path)
        try:
            done = subprocess.run([exe, str(path), "stdout", "--psm", "6", "-l", "eng"], capture_output=True, text=True, encoding="utf-8", errors="replace", timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            return None
    return done.stdout if done.returncode == 0 else None


def parse_label(text: str) -> float | None:
    """'10 µm' -> 1e-5; None unless the text is exactly one length (OCR often reads µ as u)."""
    lines = [line for line in text.splitlines() if line.strip()]
    if len(lines) != 1:
        return None
    match = LABEL.match(lines[0].replace("μ", "µ"))
    if not match:
        return None
    return float(match.group(1).replace(",", ".")) * unit_factor_m(match.group(2))


def scale_from_bar(values: np.ndarray, annotations) -> tuple[float, str] | tuple[None, str]:
    """(pixel size in m, where it came from) from a detected bar and its OCR'd label."""
    bars = [a for a in annotations if a.kind == "bar"]
    if not bars:
        return None, "no scale bar found in the image"
    if shutil.which("tesseract") is None:
        return None, "a scale bar was found, but reading its label needs Tesseract (apt-get install tesseract-ocr)"
    h, w = values.shape
    for bar in bars:
        length = bar.cols[1] - bar.cols[0]
        thick = bar.rows[1] - bar.rows[0]
        # The label sits above or below the bar, over about the bar's width.
        margin = max(6 * thick, 30)
        for r0, r1 in ((max(0, bar.rows[0] - margin), bar.rows[0]), (bar.rows[1], min(h, bar.rows[1] + margin))):
            c0, c1 = max(0, bar.cols[0] - length // 4), min(w, bar.cols[1] + length // 4)
            if r1 - r0 < 5:
                continue
            text = ocr_text(values[r0:r1, c0:c1])
            metres = parse_label(text or "")
            if metres:
                label = (text or "").strip()
                return metres / length, f"scale bar in the image: {length} px labelled '{label}' (OCR)"
    return None, "a scale bar was found, but its label did not read cleanly; no scale is known"
