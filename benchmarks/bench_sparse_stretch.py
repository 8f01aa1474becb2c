"""Sparse content through the contrast stretch: line drawings and bead fields whose content
covers 0.3-2 % of the picture, through make_lithograph with its defaults at 60, 100 and 150 mm
wide, measured against exact truth (tests/synthetic_content.py) with the content metrics
(benchmarks/content_metrics.py): members felt (top >= 0.5 mm over a 1.5 mm ring) and lines minus
the areas they enclose (mm). Prints a Markdown table.

    PYTHONPATH=src .venv/bin/python benchmarks/bench_sparse_stretch.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from content_metrics import lines_over_enclosed, members_felt, spurious  # noqa: E402
from synthetic_content import sparse_beads, sparse_strokes  # noqa: E402
from tamp_os import make_lithograph  # noqa: E402

WIDTHS_MM = (60, 100, 150)


def cases():
    for ink in (0.5, 1.0, 1.5, 2.0):
        yield sparse_strokes(ink_pct=ink)
    for count, cover in ((3, 0.3), (5, 0.6), (6, 1.0)):
        yield sparse_beads(count=count, cover_pct=cover)


def on_grid(a: np.ndarray, shape) -> np.ndarray:
    zoom = (shape[0] / a.shape[0], shape[1] / a.shape[1])
    return ndimage.zoom(a, zoom, order=0, grid_mode=True, mode="grid-constant")[: shape[0], : shape[1]]


def measure(truth, width_mm: float) -> dict:
    litho = make_lithograph(truth.image, width_mm=width_mm, scale_bar="off")
    h, mm = litho.heightmap, litho.layout.mm_per_px
    out = {"style": litho.report.relief_style, "reason": litho.report.relief_reason, "mm": mm}
    if truth.lines is not None:
        lines = on_grid(truth.lines.astype(np.uint8), h.shape) > 0
        out["metric"] = f"lines − enclosed {lines_over_enclosed(h, lines, mm):.2f} mm"
        out["spurious"] = spurious(h, lines, mm, litho.params.base_mm)
    else:
        members = on_grid(truth.members, h.shape)
        out["metric"] = f"felt {members_felt(h, members, mm):.0%} of {int(truth.members.max())}"
        out["spurious"] = spurious(h, members > 0, mm, litho.params.base_mm)
    return out


def main():
    print("| picture | width mm | content measure | spurious | style | reason (start) |")
    print("|---|---|---|---|---|---|")
    for truth in cases():
        for width in WIDTHS_MM:
            m = measure(truth, width)
            print(f"| {truth.name} | {width} | {m['metric']} | {m['spurious']} | {m['style']} | {m['reason'][:70]} |")


if __name__ == "__main__":
    main()
