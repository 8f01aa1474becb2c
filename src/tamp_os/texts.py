"""The small text languages that figure parameters are written in: a panel grid (`panels` 2x3)
and recorded panel boxes (`panel_boxes` a=x,y,w,h;…). A foundation module, so LithoParams checks
them without importing a stage (clean.panels, which finds panels, uses the same grammar)."""

from __future__ import annotations

import math
import re

from .errors import ParameterError

GRID = re.compile(r"^\s*([1-9][0-9]?)\s*[x×]\s*([1-9][0-9]?)\s*$")
# A figure prints as at most this many panels (each its own plate, plus the overview): journal
# figures carry a to l, rarely more; a 99 x 99 grid asked for 9,801 prints (issue 40.4). Grids
# (`panels` RxC) and recorded boxes (`panel_boxes`) above it are refused before any work.
MAX_PANELS = 36
# A recorded or given box (`panel_boxes`) is at least this share of the figure's shorter side on
# each side: half the share a found panel needs (whose figure may be trimmed of its margins first),
# so every recorded layout rebuilds, and a box of a few pixels is refused.
MIN_BOX_SHARE = 0.025

Box = tuple[int, int, int, int]  # x, y, w, h in source pixels


def parse_grid(text: str) -> tuple[int, int]:
    match = GRID.match(text or "")
    if not match:
        raise ParameterError(f"`panels` must be auto, off or a grid of rows × columns such as 2x3; got {text!r}.",
                             parameter="panels", value=text, allowed="auto, off, or RxC such as 2x3")
    rows, cols = int(match.group(1)), int(match.group(2))
    if rows * cols > MAX_PANELS:
        raise ParameterError(f"`panels`: a grid of at most {MAX_PANELS} panels (rows × columns, each panel its own print); "
                             f"got {text.strip()} ({rows * cols:,} panels).", parameter="panels", value=text,
                             allowed=f"RxC with R × C ≤ {MAX_PANELS}",
                             hint="Give the grid the figure has (such as 2x3), or print the figure whole with `panels` off.")
    return rows, cols


def min_box_px(width_px: int, height_px: int) -> int:
    """The smallest side a panel box may have in a figure this size (MIN_BOX_SHARE, at least 2 pixels)."""
    return max(2, math.ceil(MIN_BOX_SHARE * min(width_px, height_px)))


def parse_boxes(record: str, width_px: int | None = None, height_px: int | None = None) -> tuple[list[Box], list[str]]:
    """'a=10,10,200,150;b*=...' -> boxes and labels as written (* marks a letter inferred, not
    read); ParameterError on anything else."""
    items = [item.strip() for item in (record or "").split(";") if item.strip()]
    if len(items) > MAX_PANELS:
        raise ParameterError(f"`panel_boxes`: at most {MAX_PANELS} panels (each its own print); got {len(items):,}.",
                             parameter="panel_boxes", value=f"{len(items):,} boxes", allowed=f"2 to {MAX_PANELS} boxes",
                             hint="Give the boxes of the figure's panels only, or `panels` auto to find them.")
    shorter = min(width_px, height_px) if width_px is not None and height_px is not None else None
    boxes, labels, seen = [], [], set()
    for item in items:
        label, _, numbers = item.partition("=")
        try:
            x, y, bw, bh = (int(v) for v in numbers.split(","))
        except ValueError:
            raise ParameterError(f"`panel_boxes`: each panel is label=x,y,w,h in pixels (for example a=0,0,400,300); got {item!r}.") from None
        label = label.strip()
        if not re.fullmatch(r"[A-Za-z]\*?|[0-9]{1,3}", label) or x < 0 or y < 0 or bw < 1 or bh < 1:
            raise ParameterError(f"`panel_boxes`: each panel is a letter or number = x,y,w,h with x, y ≥ 0 and w, h ≥ 1; got {item!r}.")
        if width_px is not None and (x + bw > width_px or y + bh > height_px):
            raise ParameterError(f"`panel_boxes`: panel {label} ({x},{y},{bw},{bh}) reaches outside the {width_px}×{height_px} figure; "
                                 f"the recipe belongs to another image, or give `panels` auto.")
        if shorter is not None and min(bw, bh) < min_box_px(width_px, height_px):
            least = min_box_px(width_px, height_px)
            raise ParameterError(f"`panel_boxes`: each panel is at least {least} pixels on a side ({MIN_BOX_SHARE:.1%} of the "
                                 f"figure's shorter side, {shorter} pixels); got {label.rstrip('*')}={numbers.strip()} ({bw}×{bh} pixels).",
                                 parameter="panel_boxes", value=item, allowed=f"w, h ≥ {least} pixels",
                                 hint="Give the panel's whole box, or `panels` auto to find the panels.")
        if label.rstrip("*") in seen:
            raise ParameterError(f"`panel_boxes`: panel {label.rstrip('*')} is given twice.")
        seen.add(label.rstrip("*"))
        boxes.append((x, y, bw, bh))
        labels.append(label)
    if len(boxes) < 2:
        raise ParameterError(f"`panel_boxes`: give at least two panels (label=x,y,w,h;label=x,y,w,h); got {record!r}.")
    return boxes, labels
