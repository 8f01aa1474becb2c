"""Whether a panel's content word agrees with what its print raised (shared by the figure and content-word tests)."""

from __future__ import annotations
import time
import numpy as np
import pytest
import skimage.data
from PIL import Image, ImageDraw
from conftest import FIXTURES, need
from figures import FONT, fluorescence_composite, grid_colour
from synthetic import tem_texture
from synthetic_content import dark_line_network, dim_and_bright_beads, dot_lattice, faint_grains, line_diagram
from tamp_os.lithograph.content_word import content_word, without_corner_labels


def agrees(word, report) -> bool:
    """The word says what the print raised: its content kind (members counted within a tenth, or two),
    or "picture" when the print is no content print (a shape, a flat plate). A lattice's members are
    named as a lattice."""
    kind = report.content_kind
    if kind == "members":
        if word.kind == "lattice":
            return True
        n = report.legibility.object_count
        return word.kind == "members" and abs(word.count - n) <= max(2, 0.1 * n)
    if kind == "lines":
        return word.kind in ("lines", "line art")
    if kind == "grains":
        return word.kind == "grains"
    if kind == "plateau":
        return word.kind == "region" and word.count == int(report.legibility.object_count or 1)
    return word.kind == "picture"
