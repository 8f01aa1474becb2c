"""Issue 32, class 1: which side is specimen is decided by content, not by which phase splits into
more pieces. Bright round cells packed edge to edge, of one even brightness (no modality in the
file), make the picture's most common brightness the cells' own: they are raised as members and the
dark gaps stay at the base. Dark cells packed on bright glass are not turned over."""

from __future__ import annotations

import numpy as np
import pytest

from synthetic_content import packed_cells
from tamp_os.lithograph.pipeline import make_lithograph

RAISED_MM = 0.5


def _on_grid(labels: np.ndarray, shape) -> np.ndarray:
    rows = np.linspace(0, labels.shape[0] - 1, shape[0]).round().astype(int)
    cols = np.linspace(0, labels.shape[1] - 1, shape[1]).round().astype(int)
    return labels[rows][:, cols]


def _felt(h: np.ndarray, members: np.ndarray, ground: np.ndarray) -> float:
    """Share of the members whose median height stands RAISED_MM over the ground's median."""
    base = float(np.median(h[ground]))
    tops = [np.median(h[members == k]) for k in range(1, int(members.max()) + 1) if (members == k).sum() >= 10]
    return float(np.mean(np.asarray(tops) - base >= RAISED_MM))


@pytest.mark.timeout(120)
def test_bright_cells_packed_edge_to_edge_are_raised_and_their_gaps_stay_at_the_base():
    t = packed_cells()
    litho = make_lithograph(t.image, width_mm=100, scale_bar="off")
    h = litho.heightmap
    members = _on_grid(t.members, h.shape)
    gaps = members == 0
    assert litho.report.content_kind == "members", litho.report.relief_reason
    assert "packed edge to edge" in litho.report.relief_reason
    assert _felt(h, members, gaps) >= 0.9
    from scipy import ndimage

    inner_gaps = ndimage.binary_erosion(gaps, iterations=1)  # a grid point in from the cells' drawn edges
    assert np.median(h[members > 0]) - np.median(h[inner_gaps]) >= 1.0  # the gaps are felt low, between the cells
    said = " ".join(litho.report.legibility.verdicts)
    assert "may raise the gaps" not in said and "leaves flat" not in said and "possibly inverted" not in said, said


@pytest.mark.timeout(120)
def test_dark_cells_packed_on_bright_glass_stay_the_raised_side():
    """The same cells dark on bright glass (a brightfield smear; fewer of them, so the glass covers
    half the picture): the glass is the empty ground, the cells are raised."""
    t = packed_cells(overlap=1.0, tries=600, fibres=0)
    litho = make_lithograph(1.0 - t.image, width_mm=100, scale_bar="off")
    h = litho.heightmap
    members = _on_grid(t.members, h.shape)
    assert 0.3 < (members > 0).mean() < 0.7
    assert "packed edge to edge" not in litho.report.relief_reason
    assert np.median(h[members > 0]) > np.median(h[members == 0]) + RAISED_MM, litho.report.relief_reason


@pytest.mark.timeout(120)
def test_thin_fibres_over_cells_and_gaps_are_raised_lines_the_cells_domes_the_gaps_the_base():
    """Bright round cells on a dark filter with six thin bright fibres (about 0.4 mm wide on the
    print) crossing cells and gaps (exact truth): the cells are raised, the fibres stand as lines at
    least 0.5 mm over the gaps along most of their course there, and the gaps stay at the base."""
    from scipy import ndimage

    from synthetic_content import cells_and_fibres

    t = cells_and_fibres()
    litho = make_lithograph(t.image, width_mm=100, scale_bar="off")
    h = litho.heightmap - litho.params.base_mm
    members, fibres = _on_grid(t.members, h.shape), _on_grid(t.lines.astype(np.uint8), h.shape) > 0
    assert litho.report.content_kind == "members", litho.report.relief_reason
    assert "thin fibres" in litho.report.relief_reason
    cells = members > 0
    over_gaps = fibres & ~ndimage.binary_dilation(cells, iterations=4)
    ground = ~ndimage.binary_dilation(cells | fibres, iterations=5)
    assert float(np.median(h[ground])) <= 0.1
    assert float(np.mean(h[over_gaps] - np.median(h[ground]) >= RAISED_MM)) >= 0.7
    assert _felt(h + litho.params.base_mm, members, ground) >= 0.9


@pytest.mark.timeout(120)
def test_stress_fibres_in_one_unnamed_channel_are_oriented_ridges_not_plateaus():
    """Issue 32, class 8, beyond named dyes: straight bright fibres in a dim cell (exact truth)
    print as raised lines along the fibres (most of their course at least 0.5 mm up), the ground
    between them at the base and nothing raised as a mesa (no point over a line's height)."""
    from scipy import ndimage

    from synthetic_content import stress_fibres

    t = stress_fibres()
    litho = make_lithograph(t.image, width_mm=100, scale_bar="off")
    h = litho.heightmap - litho.params.base_mm
    fibres = _on_grid(t.lines.astype(np.uint8), h.shape) > 0
    assert litho.report.content_kind == "lines" and "straight fibres" in litho.report.relief_reason, litho.report.relief_reason
    between = ~ndimage.binary_dilation(fibres, iterations=4)
    assert float(np.median(h[between])) <= 0.1
    assert float(np.mean(h[fibres] >= RAISED_MM)) >= 0.6
    assert float(h.max()) <= 1.0 + 0.15  # raised lines 1 mm high: no 3 mm plateaus where fibres cross
