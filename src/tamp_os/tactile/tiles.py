"""Tiles: a plate larger than the printer's bed, split into the fewest tiles that fit.

The plate is cut along a rows × cols grid. Across every seam one tile carries a jigsaw peg (a
neck and a round head, through the tile's whole height) and its neighbour the matching socket,
CLEARANCE_MM larger all round, so the tiles lock in the plane and register by touch. Pegs
point right (into the next column) and down (towards the reader, into the next row).

Each tile is labelled in braille with its row and column ("⠼⠁⠀⠼⠃": row 1, column 2; row 1 is
the far edge, column 1 the left): on the flat plate margin inside the tile where there is room
(off the picture), else on a small flat pad at the tile's near left corner, which covers that
bit of the picture.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..mesh.repair import as_written
from ..mesh.solid import Mesh
from ..units import MIN_BED_MM, parse_bed_mm  # noqa: F401  (re-exported)
from .braille import BrailleSpec, block_size_mm, dot_centres

CLEARANCE_MM = 0.2  # socket larger than the peg all round: a usual FDM fit clearance
NECK_WIDTH_MM = 5.0
NECK_LENGTH_MM = 3.0
HEAD_DIAMETER_MM = 8.0
REACH_MM = NECK_LENGTH_MM + HEAD_DIAMETER_MM  # how far a peg reaches past its seam
LABEL_MARGIN_MM = 3.0  # label from the tile's edges and from anything raised
FLAT_TOLERANCE_MM = 0.05  # the margin counts as flat up to this above the base
CIRCLE_SEGMENTS = 48

Box = tuple[float, float, float, float]


@dataclass(frozen=True)
class Joint:
    """A peg on tile `peg_tile` fitting a socket on `socket_tile` (tiles as (row, col), from 1).

    `head_mm` is the centre of the peg's round head (mm, plate coordinates); `axis` is "x" for
    a peg across a vertical seam (pointing right), "y" across a horizontal one (pointing down).
    """

    peg_tile: tuple[int, int]
    socket_tile: tuple[int, int]
    axis: str
    seam_mm: float
    head_mm: tuple[float, float]


@dataclass
class Tile:
    row: int  # from 1, row 1 at the far edge (top of the image)
    col: int  # from 1, column 1 at the left
    cell_mm: Box  # the part of the plate this tile stands for, before pegs and sockets
    mesh: Mesh
    label_braille: str
    label_box_mm: Box
    label_on_margin: bool  # False: on a pad over the picture


@dataclass
class Tiling:
    rows: int
    cols: int
    bed_mm: tuple[float, float]
    tiles: list[Tile]
    joints: list[Joint]
    rotated: bool  # tiles lie on the bed turned by 90 degrees
    notes: list[str] = field(default_factory=list)


def tiles_along(length_mm: float, bed_mm: float) -> int:
    """Fewest tiles along one axis: all but the last carry a peg reaching REACH_MM past their cell."""
    if length_mm <= bed_mm:
        return 1
    return math.ceil((length_mm - REACH_MM) / (bed_mm - REACH_MM) - 1e-9)


def cell_edges(length_mm: float, count: int) -> list[float]:
    """Seam positions 0 … length_mm: every tile's outer size (cell plus peg) is the same."""
    last = (length_mm + (count - 1) * REACH_MM) / count
    edges = [0.0]
    for _ in range(count - 1):
        edges.append(edges[-1] + last - REACH_MM)
    return edges + [length_mm]


def plan_grid(plate_mm: tuple[float, float], bed_mm: tuple[float, float]) -> tuple[int, int, bool]:
    """(rows, cols, rotated): the fewest tiles, trying the bed both ways round (ties: not rotated)."""
    w, d = plate_mm
    straight = (tiles_along(d, bed_mm[1]), tiles_along(w, bed_mm[0]), False)
    turned = (tiles_along(d, bed_mm[0]), tiles_along(w, bed_mm[1]), True)
    return min(straight, turned, key=lambda g: (g[0] * g[1], g[2]))


def _joints(xs: list[float], ys_top_down: list[float]) -> list[Joint]:
    """One peg at the middle of every seam; ys_top_down runs from the far edge (row 1) down."""
    joints = []
    rows, cols = len(ys_top_down) - 1, len(xs) - 1
    head_off = NECK_LENGTH_MM + HEAD_DIAMETER_MM / 2
    for r in range(rows):
        y_mid = (ys_top_down[r] + ys_top_down[r + 1]) / 2
        for c in range(cols):
            x_mid = (xs[c] + xs[c + 1]) / 2
            if c + 1 < cols:
                joints.append(Joint((r + 1, c + 1), (r + 1, c + 2), "x", xs[c + 1], (xs[c + 1] + head_off, y_mid)))
            if r + 1 < rows:
                seam = ys_top_down[r + 1]
                joints.append(Joint((r + 1, c + 1), (r + 2, c + 1), "y", seam, (x_mid, seam - head_off)))
    return joints


def peg_section(joint: Joint, grow_mm: float = 0.0):
    """The peg's outline as a manifold3d CrossSection, or with `grow_mm` > 0 its socket: the neck
    wider by 2 × grow_mm and the head's radius larger by grow_mm (mm, plate coordinates)."""
    import manifold3d as m3

    hx, hy = joint.head_mm
    half = NECK_WIDTH_MM / 2 + grow_mm
    inside = 1.0 + grow_mm  # the neck starts inside the peg's own tile, so the union is one solid
    if joint.axis == "x":
        x0, y0, x1, y1 = joint.seam_mm - inside, hy - half, hx, hy + half
    else:
        x0, y0, x1, y1 = hx - half, hy, hx + half, joint.seam_mm + inside
    neck = m3.CrossSection([[(x0, y0), (x1, y0), (x1, y1), (x0, y1)]])
    # A new circle rather than an offset: offsetting a polygon adds tiny arcs at every corner,
    # which become sliver faces where the socket wall meets the relief.
    head = m3.CrossSection.circle(HEAD_DIAMETER_MM / 2 + grow_mm, CIRCLE_SEGMENTS).translate((hx, hy))
    return neck + head


def tile_label(row: int, col: int) -> str:
    """Row and column in Unicode braille, each a number sign and letter digits: '⠼⠁⠀⠼⠃'."""
    digits = "⠚⠁⠃⠉⠙⠑⠋⠛⠓⠊"  # 0-9 as the letters j, a-i
    return "⠀".join("⠼" + "".join(digits[int(ch)] for ch in str(n)) for n in (row, col))


def _top_within(mesh: Mesh, box: Box) -> float:
    """Highest point of the mesh over `box` (mm): the highest vertex of every face whose outline meets it."""
    tri = mesh.vertices[mesh.faces]
    lo, hi = tri[:, :, :2].min(axis=1), tri[:, :, :2].max(axis=1)
    x0, y0, x1, y1 = box
    meets = (hi[:, 0] >= x0) & (lo[:, 0] <= x1) & (hi[:, 1] >= y0) & (lo[:, 1] <= y1)
    return float(tri[meets, :, 2].max()) if meets.any() else 0.0


@dataclass
class RaisedMap:
    """Which 1 mm squares of the plate hold anything above the base (or a peg or socket), as a
    summed-area table, so that any box can be asked about in constant time."""

    table: np.ndarray  # (rows + 1, cols + 1) cumulative counts, row = floor(y), col = floor(x)

    @classmethod
    def of(cls, mesh: Mesh, base_mm: float, avoid: list[Box]) -> "RaisedMap":
        tri = mesh.vertices[mesh.faces]
        raised = tri[:, :, 2].max(axis=1) > base_mm + FLAT_TOLERANCE_MM
        lo, hi = tri[raised, :, :2].min(axis=1), tri[raised, :, :2].max(axis=1)
        if avoid:
            lo = np.vstack([lo, np.array([a[:2] for a in avoid])])
            hi = np.vstack([hi, np.array([a[2:] for a in avoid])])
        size = np.ceil(mesh.vertices[:, :2].max(axis=0)).astype(int) + 2
        lo_i = np.clip(np.floor(lo).astype(int), 0, size - 1)
        hi_i = np.clip(np.floor(hi).astype(int) + 1, 0, size - 1)
        diff = np.zeros((size[1] + 1, size[0] + 1))
        # Each box adds 1 over its squares: four corner updates, then two cumulative sums.
        for (ys, xs), sign in (((lo_i[:, 1], lo_i[:, 0]), 1), ((lo_i[:, 1], hi_i[:, 0]), -1), ((hi_i[:, 1], lo_i[:, 0]), -1), ((hi_i[:, 1], hi_i[:, 0]), 1)):
            np.add.at(diff, (ys, xs), sign)
        marked = diff.cumsum(axis=0).cumsum(axis=1)[:-1, :-1] > 0
        table = np.zeros((marked.shape[0] + 1, marked.shape[1] + 1))
        table[1:, 1:] = marked.cumsum(axis=0).cumsum(axis=1)
        return cls(table)

    def clear(self, box: Box) -> bool:
        """Whether no marked square meets `box`."""
        rows, cols = self.table.shape[0] - 1, self.table.shape[1] - 1
        c0, r0 = max(int(math.floor(box[0])), 0), max(int(math.floor(box[1])), 0)
        c1, r1 = min(int(math.ceil(box[2])), cols), min(int(math.ceil(box[3])), rows)
        t = self.table
        return t[r1, c1] - t[r0, c1] - t[r1, c0] + t[r0, c0] == 0


def _label_spot(raised: RaisedMap, cell: Box, size_mm: tuple[float, float]) -> tuple[Box, bool]:
    """Where the label goes in `cell`: the clear spot nearest the near left corner, else that corner.

    Returns (box, on_margin); clear means nothing stands above the base within LABEL_MARGIN_MM.
    """
    w, h = size_mm
    m = LABEL_MARGIN_MM
    x0, y0, x1, y1 = cell
    spots = [(x, y) for x in np.arange(x0 + m, x1 - m - w + 1e-9, 1.0) for y in np.arange(y0 + m, y1 - m - h + 1e-9, 1.0)]
    for x, y in sorted(spots, key=lambda p: (p[0] - x0) + (p[1] - y0)):
        if raised.clear((x - m, y - m, x + w + m, y + h + m)):
            return (x, y, x + w, y + h), True
    return (x0 + m, y0 + m, x0 + m + w, y0 + m + h), False


def _label_solid(mesh: Mesh, box: Box, on_margin: bool, label: str, base_mm: float, spec: BrailleSpec):
    """The label's domes (and, off the margin, the flat pad they stand on) as one manifold3d solid."""
    import manifold3d as m3

    from .furniture import braille_dome  # the caption's dome, so labels feel like the caption

    x0, y0, x1, y1 = box
    stand = base_mm if on_margin else _top_within(mesh, box)
    parts = []
    if not on_margin:  # the pad reaches down into the base, so it overlaps instead of touching
        parts.append(m3.Manifold.extrude(m3.CrossSection([[(x0, y0), (x1, y0), (x1, y1), (x0, y1)]]), stand - base_mm / 2).translate((0, 0, base_mm / 2)))
    dome = braille_dome(spec, min(0.4, base_mm / 2))
    parts += [dome.translate((x, y, stand)) for x, y in dot_centres([label], spec, x0, top_mm=y1)]
    return m3.Manifold.batch_boolean(parts, m3.OpType.Add)


def _region(cell: Box, row: int, col: int, joints: list[Joint]):
    """The tile's outline: its cell, plus the pegs it carries, minus its sockets (CLEARANCE_MM larger)."""
    import manifold3d as m3

    x0, y0, x1, y1 = cell
    region = m3.CrossSection([[(x0, y0), (x1, y0), (x1, y1), (x0, y1)]])
    for joint in joints:
        if joint.peg_tile == (row, col):
            region = region + peg_section(joint)
    for joint in joints:
        if joint.socket_tile == (row, col):
            region = region - peg_section(joint, CLEARANCE_MM)
    return region


def _solid(mesh: Mesh):
    import manifold3d as m3

    return m3.Manifold(
        m3.Mesh(vert_properties=np.ascontiguousarray(mesh.vertices, dtype=np.float32), tri_verts=np.ascontiguousarray(mesh.faces, dtype=np.uint32))
    )


def make_tiles(mesh: Mesh, bed_mm: tuple[float, float], base_mm: float, *, spec: BrailleSpec, keep_clear: list[Box] = ()) -> Tiling | None:
    """Split the plate `mesh` (mm, outline from (0, 0)) into tiles that fit a bed of `bed_mm`.

    Parameters
    ----------
    mesh : Mesh
        The whole print, its plate from (0, 0) to (width, depth) mm, bottom at z = 0.
    bed_mm : (width, depth)
        The printer's bed in mm; a tile may lie on it turned by 90 degrees.
    base_mm : float
        The plate thickness: labels stand on it where it is bare.
    keep_clear : list of (x0, y0, x1, y1) boxes in mm
        Where labels must not go (the picture, the cut corner).

    Returns None when the plate fits the bed as it is.
    """
    import manifold3d as m3

    from .furniture import to_mesh

    plate_w, plate_d = (float(v) for v in mesh.vertices[:, :2].max(axis=0))
    rows, cols, rotated = plan_grid((plate_w, plate_d), bed_mm)
    if rows * cols == 1:
        return None
    xs, ys_up = cell_edges(plate_w, cols), cell_edges(plate_d, rows)
    ys = ys_up[::-1]  # row 1 is the far edge
    joints = _joints(xs, ys)
    sockets = [_bounds(peg_section(j, CLEARANCE_MM + LABEL_MARGIN_MM)) for j in joints]
    raised = RaisedMap.of(mesh, base_mm, list(keep_clear) + sockets)
    whole = _solid(mesh)
    top = float(mesh.vertices[:, 2].max()) + 2 * spec.dot_height_mm + 1.0
    tiles = []
    for r in range(rows):
        for c in range(cols):
            cell = (xs[c], ys[r + 1], xs[c + 1], ys[r])
            cutter = m3.Manifold.extrude(_region(cell, r + 1, c + 1, joints), top + 1.0).translate((0, 0, -1.0))
            piece = whole ^ cutter
            label = tile_label(r + 1, c + 1)
            box, on_margin = _label_spot(raised, cell, block_size_mm([label], spec))
            piece = piece + _label_solid(mesh, box, on_margin, label, base_mm, spec)
            # a cut through a fine relief can leave faces of no area once written as float32
            tiles.append(Tile(r + 1, c + 1, cell, as_written(to_mesh(piece)), label, box, on_margin))
    notes = [
        f"tiles: the label of tile {t.row}-{t.col} stands on a small pad over the picture (no bare margin in that tile)."
        for t in tiles
        if not t.label_on_margin
    ]
    return Tiling(rows, cols, bed_mm, tiles, joints, rotated, notes)


def _bounds(section) -> Box:
    x0, y0, x1, y1 = section.bounds()
    return (x0, y0, x1, y1)


def describe_tiles(tiling: Tiling) -> str:
    """How the tiles go together, for the description."""
    bed_w, bed_d = tiling.bed_mm
    turned = " (turned by 90 degrees on the bed)" if tiling.rotated else ""
    return (
        f"The print is too large for a {bed_w:g} by {bed_d:g} mm bed, so it comes as {tiling.rows * tiling.cols} tiles in "
        f"{tiling.rows} row{'s' if tiling.rows > 1 else ''} and {tiling.cols} column{'s' if tiling.cols > 1 else ''}{turned}, "
        "files NAME.tile-R-C (row R counted from the far edge, column C from the left). Each tile carries its row "
        "and column in braille, as two numbers, on a bare margin of the tile where it has one, else on a small flat pad at its near left corner. A round-headed peg on the right edge "
        "and on the near edge of a tile fits a matching socket in the next tile to the right and the next tile "
        f"towards you ({CLEARANCE_MM:g} mm clearance): lay the tiles out by their labels and press each peg into "
        "its socket from above."
    )


def tiles_for(mesh: Mesh, bed_mm: tuple[float, float], base_mm: float, *, spec: BrailleSpec, picture_box: Box, corner_legs_mm: float = 0.0) -> Tiling | None:
    """make_tiles for a finished print, keeping the labels off the picture and the cut corner.

    `picture_box` is the relief's outline on the plate (mm); `corner_legs_mm` the cut corner's legs.
    """
    plate_w, plate_d = (float(v) for v in mesh.vertices[:, :2].max(axis=0))
    keep_clear = [picture_box]
    if corner_legs_mm:
        keep_clear.append((plate_w - corner_legs_mm, plate_d - corner_legs_mm, plate_w, plate_d))
    return make_tiles(mesh, bed_mm, base_mm, spec=spec, keep_clear=keep_clear)
