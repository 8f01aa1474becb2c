"""The regions a reader touches, named and placed, for the eBraille package and the touch tour (issue 35).

The regions are the plate's and the pin displays' own: the layers export.pins reads from a
lithograph (members, lines, areas, a channel print's key entries), each connected piece one
region, plus the furniture the plate carries (the cut corner, the scale bar and its value, the
caption, the key rows) at the places the 2-D graphic (graphic2d.Graphic2D) puts them.

Each region has an id, a label and a description in print words (the tour's words: what it is,
its size in µm and in mm on the plate where the scale is known, and where it is: "upper left"),
an outline as an SVG path in page millimetres (y down, the plate's far edge at the top, as the
tactile SVG is drawn), and a touch point inside it that no region drawn above it covers.

The tour reads them in order: the orientation corner first, then the picture and its regions
top to bottom (by thirds of the picture: upper, middle, lower) and left to right, then the scale
bar, the caption and the key, as they lie below the picture.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import logging

import numpy as np

from ..units import format_length
from .graphic2d import Graphic2D

log = logging.getLogger(__name__)

MAX_PICTURE_REGIONS = 40  # more than this is not a tour; the largest are kept and the rest counted
MIN_REGION_MM2 = 1.0  # a piece smaller than a fingertip's square millimetre is not a stop on the tour
MIN_TOUCH_DEPTH_PX = 2.0  # a touch point lies this far inside its region's own part (outlines are simplified)
MAX_OUTLINE_PARTS = 2000  # outlines (holes and specks too) the tour's regions draw in all, each simplified (~1.5 ms)
NOUNS = {"members": "dome", "dots": "dot", "lines": "raised line", "areas": "raised area"}
DRAW_ORDER = {"picture": 0, "areas": 1, "lines": 2, "members": 3, "dots": 3, "furniture": 4}


@dataclass(frozen=True)
class Region:
    """One thing on the plate, in print words; `path` and `touch` in page mm (y down)."""

    id: str
    kind: str  # 'furniture', 'picture', 'members', 'dots', 'lines', 'areas'
    label: str  # short: 'dome 2 of 4', 'scale bar'
    description: str  # a sentence: what it is, its size, where it is
    path: str  # SVG path data in page millimetres
    touch: tuple[float, float]  # a point inside the region that no region drawn above it covers
    box: tuple[float, float, float, float]  # x0, y0, x1, y1 (page mm)

    @property
    def spoken(self) -> str:
        return f"{self.label}. {self.description}"


def where_words(fx: float, fy: float) -> str:
    """A place in a rectangle from its fractions across (0 left) and down (0 top): 'upper left', 'centre'."""
    vertical = "upper" if fy < 1 / 3 else "lower" if fy > 2 / 3 else "middle"
    horizontal = "left" if fx < 1 / 3 else "right" if fx > 2 / 3 else "centre"
    if (vertical, horizontal) == ("middle", "centre"):
        return "centre"
    return f"{vertical} {horizontal}" if horizontal != "centre" else f"{vertical} middle" if vertical != "middle" else "centre"


def length_words(metres: float) -> str:
    """A length as read aloud, to two significant figures: '2.3 µm', '410 nm'."""
    return format_length(float(f"{metres:.2g}"))


def mm_words(mm: float) -> str:
    return f"{round(mm, 1):g} mm"


def _rect_path(x0, y0, x1, y1) -> str:
    return f"M{x0:.2f} {y0:.2f}H{x1:.2f}V{y1:.2f}H{x0:.2f}Z"


def _contours(piece: "_Piece") -> list[np.ndarray]:
    """The outlines of a piece (holes too) in picture pixels, through pixel edges: found on its own
    box, not the whole picture (a picture of 40 regions at 1000² px spent 8 s on whole-picture masks)."""
    from skimage.measure import find_contours

    (r0, _), (c0, _) = ((b.start, b.stop) for b in piece.box)
    return [c + (r0 - 1.0, c0 - 1.0) for c in find_contours(np.pad(piece.mask.astype(np.float32), 1), 0.5)]


def _outline_budget(counts: list[int], budget: int = MAX_OUTLINE_PARTS) -> int:
    """The most outline parts each region keeps so that all of them keep at most `budget` in all
    (the largest: a hole or speck of a region with thousands is smaller than a fingertip finds)."""
    if sum(counts) <= budget:
        return max(counts, default=0)
    low, high = 1, max(counts)
    while low < high:  # the largest cap whose total fits
        mid = (low + high + 1) // 2
        low, high = (mid, high) if sum(min(n, mid) for n in counts) <= budget else (low, mid - 1)
    return low


def _contour_path(contours: list[np.ndarray], to_page, keep: int) -> str:
    """Path data in page mm of the `keep` largest outlines (filled even-odd), in the order found."""
    from skimage.measure import approximate_polygon

    if len(contours) > keep:
        extent = [float(np.ptp(c[:, 0]) + 1) * float(np.ptp(c[:, 1]) + 1) for c in contours]
        chosen = set(sorted(range(len(contours)), key=lambda i: -extent[i])[:keep])
        contours = [c for i, c in enumerate(contours) if i in chosen]
    parts = []
    for contour in contours:
        contour = approximate_polygon(contour, tolerance=0.25)
        if len(contour) < 3:
            continue
        points = [to_page(r + 0.5, c + 0.5) for r, c in contour]  # contours run through pixel centres
        parts.append("M" + "L".join(f"{x:.2f} {y:.2f}" for x, y in points) + "Z")
    return "".join(parts)


def _inner_point(mask: np.ndarray) -> tuple[tuple[int, int] | None, float]:
    """The pixel of `mask` farthest from its edge (row, col) and its distance from the edge in
    pixels; (None, 0) for an empty mask."""
    from scipy.ndimage import distance_transform_edt

    if not mask.any():
        return None, 0.0
    distance = distance_transform_edt(np.pad(mask, 1))[1:-1, 1:-1]
    r, c = np.unravel_index(int(np.argmax(distance)), distance.shape)
    return (int(r), int(c)), float(distance[r, c])


@dataclass
class _Piece:
    kind: str
    label: str  # the layer's key label
    mask: np.ndarray  # the piece within its box
    area_px: int
    box: tuple[slice, slice]  # where `mask` lies in the picture: its bounding box

    def where(self) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns (in the picture) of the piece's pixels."""
        ys, xs = np.nonzero(self.mask)
        return ys + self.box[0].start, xs + self.box[1].start


def _layer_labels(layer, shape) -> np.ndarray:
    """A layer's pieces as labels (members and areas by their labels, lines by 8-connectivity)."""
    from skimage.measure import label as cc_label

    data = np.asarray(layer.data)[: shape[0], : shape[1]]
    return cc_label(data.astype(bool), connectivity=2) if layer.kind == "lines" else data.astype(np.int64)


def picture_regions(layers, shape: tuple[int, int], graphic: Graphic2D, *, um_per_px: float | None
                    ) -> tuple[list[Region], int, tuple[float, float] | None]:
    """The picture's regions in reading order, how many smaller pieces were left out, and a point
    of the picture (page mm) that no region covers (None when they cover it all)."""
    rows, cols = shape
    px0, py0, px1, py1 = graphic.picture_box
    plate_d = graphic.plate_mm[1]
    sx, sy = (px1 - px0) / cols, (py1 - py0) / rows
    top = plate_d - py1  # the picture's top edge on the page

    def to_page(r, c):
        return px0 + c * sx, top + r * sy

    pieces, left_out = _kept_pieces(layers, shape, (sx, sy))
    placed = []
    for piece in pieces:
        ys, xs = piece.where()
        cy, cx = (ys.mean() + 0.5) / rows, (xs.mean() + 0.5) / cols
        band = min(2, int(cy * 3))
        placed.append((band, cx, cy, piece, ys, xs))
    placed.sort(key=lambda t: (t[0], t[1], t[2]))
    placed, touch_of, above = _touch_points(placed, shape)
    counts: dict[tuple[str, str], int] = {}
    for _, _, _, piece, _, _ in placed:
        counts[(piece.kind, piece.label)] = counts.get((piece.kind, piece.label), 0) + 1
    outlines = [_contours(piece) for _, _, _, piece, _, _ in placed]
    keep = _outline_budget([len(c) for c in outlines])
    if any(len(c) > keep for c in outlines):
        log.info("region outlines: %d parts in all; each region keeps its %d largest", sum(map(len, outlines)), keep)
    seen: dict[tuple[str, str], int] = {}
    regions = []
    for index, (_, cx, cy, piece, ys, xs) in enumerate(placed):
        key = (piece.kind, piece.label)
        seen[key] = seen.get(key, 0) + 1
        label = _piece_label(piece, seen[key], counts[key])
        r, c = touch_of[index]
        x0, y0 = to_page(ys.min(), xs.min())
        x1, y1 = to_page(ys.max() + 1, xs.max() + 1)
        regions.append(Region(
            f"r{index + 1}", piece.kind, label, _piece_description(piece, sx, sy, um_per_px, (x1 - x0, y1 - y0), where_words(cx, cy)),
            _contour_path(outlines[index], to_page, keep), to_page(r + 0.5, c + 0.5), (x0, y0, x1, y1)))
    ground, _ = _inner_point(~above)
    return regions, left_out, (to_page(ground[0] + 0.5, ground[1] + 0.5) if ground else None)


def _kept_pieces(layers, shape: tuple[int, int], mm_per_px: tuple[float, float]) -> tuple[list[_Piece], int]:
    """The pieces large enough to be regions (a plateau counted without the domes on it), at most
    MAX_PICTURE_REGIONS of them, the largest first when there are more; and how many were left out.

    Priced before anything is built per piece: the pieces are counted and measured from their
    labels (one pass over each layer), and only those kept get a mask, of their own box. (A
    checkerboard's 1,250 squares each made a whole-picture mask first: 1.4 GB at 1000² px.)"""
    from scipy.ndimage import find_objects

    labelled = [(layer, _layer_labels(layer, shape)) for layer in layers]
    raised_by_others = np.zeros(shape, bool)
    for layer, labels in labelled:
        if layer.kind != "areas":
            raised_by_others |= labels != 0
    sx, sy = mm_per_px
    found = []  # (layer index, value, area px) in the order the layers and their labels come
    for i, (layer, labels) in enumerate(labelled):
        counts = np.bincount(labels.ravel())
        if layer.kind == "areas":  # a plateau holds the domes on it: its own part is what is left around them
            own = np.bincount(labels[~raised_by_others].ravel(), minlength=len(counts))
        for value in np.flatnonzero(counts):
            if value == 0:
                continue
            area = int(own[value]) if layer.kind == "areas" else int(counts[value])
            if area * sx * sy >= MIN_REGION_MM2:
                found.append((i, int(value), area))
    log.debug("tour regions: %d pieces counted, %d of at least %g mm²", sum(int(labels.max(initial=0)) for _, labels in labelled),
              len(found), MIN_REGION_MM2)
    left_out = 0
    if len(found) > MAX_PICTURE_REGIONS:
        found.sort(key=lambda f: -f[2])
        left_out = len(found) - MAX_PICTURE_REGIONS
        found = found[:MAX_PICTURE_REGIONS]
    boxes = {i: find_objects(labels) for i, (_, labels) in enumerate(labelled) if any(f[0] == i for f in found)}
    pieces = []
    for i, value, area in found:
        layer, labels = labelled[i]
        box = boxes[i][value - 1]
        pieces.append(_Piece(layer.kind, layer.label, labels[box] == value, area, box))
    return pieces, left_out


def _touch_points(placed: list, shape: tuple[int, int]) -> tuple[list, dict, np.ndarray]:
    """Each placed piece's touch point (row, col), the pieces kept (in their order) and what all of
    them cover. Areas lie under lines under members when drawn: a touch point avoids what is above."""
    above = np.zeros(shape, bool)
    touch_of = {}
    for index in sorted(range(len(placed)), key=lambda i: -DRAW_ORDER.get(placed[i][3].kind, 2)):
        piece = placed[index][3]
        point, depth = _inner_point(piece.mask & ~above[piece.box])
        if depth < MIN_TOUCH_DEPTH_PX:
            if piece.kind == "areas":  # a thin rim around the domes on it: felt as the domes, not a stop of its own
                continue
            point, depth = _inner_point(piece.mask)
        touch_of[index] = (point[0] + piece.box[0].start, point[1] + piece.box[1].start)
        above[piece.box] |= piece.mask
    kept = [p for i, p in enumerate(placed) if i in touch_of]
    return kept, {new: touch_of[old] for new, old in enumerate(sorted(touch_of))}, above


def _piece_label(piece: _Piece, number: int, total: int) -> str:
    generic = piece.label in ("members, domes", "the shape", "raised parts", "raised areas", "plateau", "lines", "grain outlines, lines")
    noun = NOUNS.get(piece.kind, "region") if generic else piece.label
    if piece.label == "plateau":
        noun = "plateau"
    if piece.label == "grain outlines, lines":
        noun = "grain outlines"
    if piece.kind == "lines" and total == 1 and generic:
        noun = "line network"
    return noun if total == 1 else f"{noun} {number} of {total}"


def _piece_description(piece: _Piece, sx: float, sy: float, um_per_px: float | None, extent_mm, where: str) -> str:
    text = _piece_words(piece, sx, sy, um_per_px, extent_mm, where)
    return text[:1].upper() + text[1:]


def _piece_words(piece: _Piece, sx: float, sy: float, um_per_px: float | None, extent_mm, where: str) -> str:
    if piece.kind == "lines":
        w, h = extent_mm
        size = f"spanning {mm_words(w)} by {mm_words(h)} on the plate"
        if um_per_px:
            size += f" ({length_words(w / sx * um_per_px * 1e-6)} by {length_words(h / sy * um_per_px * 1e-6)} in the sample)"
        what = "a network of raised lines" if "grain" in piece.label or piece.label == "lines" else f"raised lines: {piece.label}"
        return f"{what}, {size}, {where}."
    diameter_px = 2 * math.sqrt(piece.area_px / math.pi)
    size = f"about {mm_words(diameter_px * math.sqrt(sx * sy))} across on the plate"
    if um_per_px:
        size = f"about {length_words(diameter_px * um_per_px * 1e-6)} across in the sample ({mm_words(diameter_px * math.sqrt(sx * sy))} on the plate)"
    what = {"members": "a dome", "dots": "a raised dot", "areas": "a raised area"}.get(piece.kind, "a region")
    if piece.label not in ("members, domes", "raised parts", "raised areas", "the shape"):
        what = f"{what}, {piece.label}"
    return f"{what}, {size}, {where}."


def furniture_regions(graphic: Graphic2D, caption: str | None, key_labels: list[str]) -> dict[str, Region]:
    """The cut corner, the scale bar and its value, the caption and the key rows, by name."""
    w, d = graphic.plate_mm

    def page_box(box):
        x0, y0, x1, y1 = box
        return x0, d - y1, x1, d - y0

    def rect(rid, label, description, box):
        x0, y0, x1, y1 = page_box(box)
        return Region(rid, "furniture", label, description, _rect_path(x0, y0, x1, y1), ((x0 + x1) / 2, (y0 + y1) / 2), (x0, y0, x1, y1))

    out = {}
    c = graphic.corner_cut_mm
    if c > 0:
        out["corner"] = Region(
            "corner", "furniture", "orientation corner",
            "The top right corner of the plate is cut off. Start here: hold the plate with this corner at the top right, "
            "and the top of the picture is the far edge.",
            f"M{w - c:.2f} 0H{w:.2f}V{c:.2f}Z", (w - c / 3, c / 3), (w - c, 0.0, w, c))
    px0, py0, px1, py1 = graphic.picture_box
    out["picture"] = rect("picture", "the picture",
                          f"The picture, {mm_words(px1 - px0)} wide and {mm_words(py1 - py0)} deep, at the top of the plate; "
                          "the regions on it follow, top to bottom and left to right.", graphic.picture_box)
    out["picture"] = dataclasses.replace(out["picture"], kind="picture")  # drawn under the regions on it
    bar = graphic.scale_bar
    if bar is not None:
        out["scale-bar"] = rect("scale-bar", "scale bar",
                                f"A raised bar with end ticks, {mm_words(bar.length_mm)} long on the plate, stands for {bar.text} in the sample; "
                                "it lies below the picture at the left.", bar.box())
        out["scale-value"] = rect("scale-value", "scale value", f"The value of the bar in braille, {bar.text}, to the right of the bar.",
                                  bar.label.box(graphic.spec))
    if graphic.caption is not None:
        out["caption"] = rect("caption", "caption", f"The braille caption along the bottom margin reads: {caption or 'the picture'}.",
                              graphic.caption.box(graphic.spec))
    for i, row in enumerate(graphic.key):
        label = key_labels[i] if i < len(key_labels) else f"entry {i + 1}"
        texture = {"outline": "an outlined area", "dots": "a dotted area", "lines": "an area of parallel lines"}.get(row.texture, row.texture)
        x0, y0, x1, y1 = row.swatch_box
        lx0, ly0, lx1, ly1 = row.label.box(graphic.spec)
        out[f"key-{i + 1}"] = rect(f"key-{i + 1}", f"key: {label}",
                                   f"Key entry {i + 1} of {len(graphic.key)}, at the bottom of the plate: a swatch of {texture}, then its braille label, {label}.",
                                   (min(x0, lx0), min(y0, ly0), max(x1, lx1), max(y1, ly1)))
    return out


@dataclass(frozen=True)
class Tour:
    title: str
    intro: str
    regions: tuple[Region, ...]  # in reading order: corner, picture, its regions, scale bar, caption, key
    plate_mm: tuple[float, float]


def tour_of(graphic: Graphic2D, layers, shape, *, um_per_px: float | None, title: str, caption: str | None,
            key_labels: list[str]) -> Tour:
    """The touch tour of a 2-D graphic and the layers it shows."""
    furniture = furniture_regions(graphic, caption, key_labels)
    picture, left_out, ground = picture_regions(layers, shape, graphic, um_per_px=um_per_px)
    if ground is not None:  # touching the picture where nothing is raised names the picture
        furniture["picture"] = dataclasses.replace(furniture["picture"], touch=ground)
    order = [furniture[k] for k in ("corner", "picture") if k in furniture] + picture
    order += [furniture[k] for k in ("scale-bar", "scale-value", "caption") if k in furniture]
    order += [furniture[k] for k in sorted(furniture) if k.startswith("key-")]
    w, d = graphic.plate_mm
    counted = f"{len(picture)} region{'s' * (len(picture) != 1)} on the picture"
    if left_out:
        counted += f" (the largest; {left_out} smaller ones are left out of the tour)"
    scale = f" One pixel of the picture is {length_words(um_per_px * 1e-6)} in the sample." if um_per_px else " No physical scale is known."
    intro = (f"{title}. The plate is {mm_words(w)} wide and {mm_words(d)} deep. The tour starts at the orientation corner, "
             f"then reads {counted}, top to bottom and left to right, then what lies below the picture.{scale}")
    return Tour(title, intro, tuple(order), graphic.plate_mm)


def tour_from_lithograph(litho, graphic: Graphic2D) -> Tour:
    """The tour of a lithograph's plate, with the pin displays' layers (export.pins)."""
    from .pins import source_from_lithograph

    source = source_from_lithograph(litho)
    key_labels = [entry.label for entry in (litho.report.key or ())]
    caption = litho.params.caption
    return tour_of(graphic, source.layers, source.shape, um_per_px=source.um_per_px, title=source.title, caption=caption, key_labels=key_labels)


def labelled_svg(base_svg: str, tour: Tour, label_of=None, *, title: str | None = None, touch_attrs: bool = True,
                 document_role: bool = True) -> str:
    """The tactile SVG (cairo's drawing) with a layer of labelled regions on top: each region a path
    with role="graphics-object", an id and aria-label (`label_of(region)`, print by default), drawn
    in the reading order's draw order so a touch point lands on its own region.

    document_role: the root says role="graphics-document" (the tour page); an EPUB content
    document's inline SVG may carry no such role (epubcheck's schema)."""
    from .markup import escape, quoteattr

    label_of = label_of or (lambda r: r.label)
    head_start = base_svg.index("<svg")
    head_end = base_svg.index(">", head_start)
    head = base_svg[head_start:head_end]
    body = base_svg[head_end + 1 : base_svg.rindex("</svg>")]
    body = body.split("</title>", 1)[1] if "<title>" in body else body  # our own title replaces it
    name = title if title is not None else tour.title
    role = ' role="graphics-document"' if document_role else ""  # EPUB's schema allows no graphics role on an inline <svg>
    out = [f'{head}{role} aria-labelledby="graphic-title">',
           f'<title id="graphic-title">{escape(name)}</title>',
           '<g aria-hidden="true">' + body + "</g>",
           '<g id="regions" fill="#000" fill-opacity="0" fill-rule="evenodd" stroke="none">']
    drawn = sorted(tour.regions, key=lambda r: DRAW_ORDER.get(r.kind, 2))
    for region in drawn:
        extra = f' data-x="{region.touch[0]:.2f}" data-y="{region.touch[1]:.2f}"' if touch_attrs else ""
        out.append(f'<path id="{region.id}" role="graphics-object" aria-label={quoteattr(label_of(region))}{extra} d="{region.path}"/>')
    out.append("</g>")
    out.append("</svg>")
    return "\n".join(out)


def plain_svg(graphic: Graphic2D, title: str) -> str:
    """Cairo's tactile SVG of `graphic` at the plate's own size, as text."""
    import io

    from .tactile2d import write_svg

    buffer = io.BytesIO()
    write_svg(graphic, buffer, None, metadata={"title": title})
    return buffer.getvalue().decode("utf-8")
