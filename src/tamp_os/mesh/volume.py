"""A volume (a z-stack, a density map) as one watertight solid: the voxel steps before meshing.

All in voxel space, with the voxel's size on the print in millimetres (`spacing_mm`, z y x):

- `otsu_level` chooses the isosurface level from the content (Otsu's threshold of the values);
- `solid_mask` thresholds, drops specks smaller than `speck_mm3`, and fills internal voids
  (binary fill holes: a hollow object prints as a solid one, a void no finger can reach);
- `thicken` grows walls thinner than `min_wall_mm` (a distance-transform dilation restricted to
  the thin parts), except where growing would join parts or close a hole: those it lists;
- `surface_field` turns the values into a signed field whose zero is the surface: the data's own
  (interpolated, so the surface lies between voxels where the values say) where the mask kept it,
  positive in filled voids, negative in dropped specks, and the thickening's distance where walls grew;
- `isosurface` meshes that field by marching cubes (scikit-image), padded with empty voxels so the
  surface is always closed.

Orientation (once, here): column -> +x, row 0 (the top of the image) at the far edge (+y largest),
slice index -> +z (up). Seen from above, the model looks like the stack's maximum projection.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .solid import INDEX, Mesh

PAD_VOXELS = 2
NUDGE = np.float32(0.01)


@dataclass(frozen=True)
class ThinRegion:
    """A thin part left as it is: where (x0, y0, z0, x1, y1, z1 on the model, mm), how thick across its
    ridge (the median), and why."""

    box_mm: tuple[float, ...]
    thinnest_mm: float
    why: str

    def words(self) -> str:
        b = self.box_mm
        return (f"{self.thinnest_mm:.2f} mm thick at x {b[0]:.1f}–{b[3]:.1f}, y {b[1]:.1f}–{b[4]:.1f}, z {b[2]:.1f}–{b[5]:.1f} mm "
                f"(thickening it {self.why})")


@dataclass
class MaskReport:
    """What the voxel steps did, for the report."""

    level: float
    voxels: int = 0
    specks_dropped: int = 0
    voids_filled: int = 0
    void_voxels: int = 0
    components: int = 0
    thin_voxels: int = 0
    grown_mm: float = 0.0
    joined: int = 0  # parts that thickening joined (were apart, now touch)
    thin_regions_mm: list = field(default_factory=list)  # (x0, y0, z0, x1, y1, z1) boxes of thin parts, print mm
    thin_grown: int = 0  # thin parts grown to the wall
    thin_left: list = field(default_factory=list)  # ThinRegion: thin parts left thin, since growing them changes the structure
    grow_field: np.ndarray | None = field(default=None, repr=False)  # grown_mm − distance to the thin parts (mm)


def otsu_level(values: np.ndarray, sample: int = 4_000_000) -> float:
    """Otsu's threshold of the finite values (every k-th voxel of a large volume)."""
    from skimage.filters import threshold_otsu

    flat = values.ravel()
    step = max(1, flat.size // sample)
    finite = flat[::step]
    finite = finite[np.isfinite(finite)]
    if finite.size == 0 or finite.min() == finite.max():
        return float(finite.min()) if finite.size else 0.0
    return float(threshold_otsu(finite))


def _structure():
    from scipy import ndimage

    return ndimage.generate_binary_structure(3, 1)  # faces only: what a finger and a slicer see as joined


def solid_mask(values: np.ndarray, level: float, spacing_mm, *, speck_mm3: float) -> tuple[np.ndarray, MaskReport]:
    """The voxels above `level`, specks under `speck_mm3` dropped, internal voids filled."""
    from scipy import ndimage

    report = MaskReport(level=float(level))
    mask = values > level
    voxel_mm3 = float(np.prod(spacing_mm))
    labels, n = ndimage.label(mask, structure=_structure())
    if n:
        sizes = np.bincount(labels.ravel())[1:]
        small = np.flatnonzero(sizes * voxel_mm3 < speck_mm3) + 1
        report.specks_dropped = int(small.size)
        if small.size:
            mask &= ~np.isin(labels, small)
    del labels
    filled = ndimage.binary_fill_holes(mask, structure=_structure())
    voids = filled & ~mask
    report.void_voxels = int(voids.sum())
    if report.void_voxels:
        report.voids_filled = int(ndimage.label(voids, structure=_structure())[1])
    del voids
    report.voxels = int(filled.sum())
    report.components = int(ndimage.label(filled, structure=_structure())[1]) if report.voxels else 0
    return filled, report


def _thin_parts(mask: np.ndarray, spacing: np.ndarray, min_wall_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """(the thin voxels, the depth of every voxel inside the mask in mm).

    The thin voxels are those a ball of diameter `min_wall_mm` cannot reach from inside (the mask
    minus its morphological opening, by distance transforms; a voxel's depth is counted from the
    surface half a voxel outside its outer centres). Parts smaller than such a ball, and the edges and
    corners of thick parts (all within a wall's thickness of the balls that fill them), are not walls.
    """
    from scipy import ndimage

    vox, radius = float(spacing.max()), min_wall_mm / 2
    inside = ndimage.distance_transform_edt(mask, sampling=spacing)
    core = inside - 0.5 * vox >= radius - 0.25 * vox  # centres of wall-sized balls that fit inside (a quarter voxel spare)
    reach = ndimage.distance_transform_edt(~core, sampling=spacing) if core.any() else np.full(mask.shape, np.inf)
    thin = mask & (reach > radius + 0.5 * vox)
    del core
    labels, n = ndimage.label(thin, structure=_structure())
    if n:
        sizes = np.bincount(labels.ravel())[1:] * float(np.prod(spacing))
        where = labels > 0  # the statistics over the thin voxels alone (the same, without sorting the whole grid)
        farthest = np.asarray(ndimage.maximum(reach[where], labels[where], np.arange(1, n + 1)), dtype=float).reshape(-1)
        corners = np.flatnonzero((sizes < np.pi / 6 * min_wall_mm ** 3) | (farthest <= min_wall_mm)) + 1
        if corners.size:
            thin &= ~np.isin(labels, corners)
    return thin, inside


def thicken(mask: np.ndarray, spacing_mm, min_wall_mm: float, *, report: MaskReport) -> np.ndarray:
    """Walls thinner than `min_wall_mm` grown until they are that thick, where growing them keeps the
    structure; the rest unchanged.

    The thin parts (`_thin_parts`) grow, each near itself only, to the union of balls of diameter
    `min_wall_mm` (and a quarter voxel) centred on their middle ridge (the voxels deepest across the
    wall) and of the part grown by what its wall lacks, so every wall there reaches the threshold and
    thick parts keep their size. A thin part
    whose growth would touch another part that was apart, or would close a hole through the model or
    open a cavity (the Euler number of its neighbourhood changes), is left as it is and listed in
    `report.thin_left` (where, how thin, why): growing it would change what the model shows.

    The work is done in the mask's bounding box with a margin wider than any growth and its
    neighbourhood (the same result: every distance inside the mask is to a voxel in that box); a
    model in a fraction of its grid costs that fraction.
    """
    spacing = np.asarray(spacing_mm, dtype=float)
    radius = min_wall_mm / 2
    if not mask.any() or radius <= 0:
        return mask
    margin = _growth_pad(spacing, radius) + 3  # wider than a part's growth box, and a clear shell beyond it
    along = [np.flatnonzero(mask.any(axis=tuple(a for a in range(3) if a != k))) for k in range(3)]
    crop = tuple(slice(max(int(e[0]) - margin, 0), min(int(e[-1]) + 1 + margin, n)) for e, n in zip(along, mask.shape))
    inner = _thicken_box(mask[crop], spacing, min_wall_mm, report=report, offset=tuple(c.start for c in crop), shape=mask.shape)
    if inner is None:
        return mask
    out = mask.copy()
    out[crop] = inner
    field_ = np.full(mask.shape, -np.float32(_ridge_reach(spacing, radius)), np.float32)  # _Growth's "not grown"
    field_[crop] = report.grow_field
    report.grow_field = field_
    return out


def _thicken_box(mask: np.ndarray, spacing: np.ndarray, min_wall_mm: float, *, report: MaskReport, offset, shape) -> np.ndarray | None:
    """`thicken` in a box of the grid at `offset` of a grid of `shape`: the box's new mask, or None when nothing is thin."""
    from scipy import ndimage

    vox, radius = float(spacing.max()), min_wall_mm / 2
    thin, inside = _thin_parts(mask, spacing, min_wall_mm)
    report.thin_voxels = int(thin.sum())
    if not report.thin_voxels:
        return None
    parts, n = ndimage.label(thin, structure=_structure())
    boxes = ndimage.find_objects(parts)
    report.thin_regions_mm = [_box_mm(_moved(b, offset), spacing, shape) for b in boxes[:20]]
    # Each part's middle ridge: the voxels deepest across the wall (a part with none grows from all of its voxels).
    ridge = thin & (inside >= ndimage.maximum_filter(inside, size=3) - 1e-9)
    has_ridge = np.zeros(n + 1, bool)
    has_ridge[np.unique(parts[ridge])] = True
    centres = ridge | (thin & ~has_ridge[parts])
    del ridge, thin
    index = np.arange(1, n + 1)
    # How thin each part is: across its ridge (the median, so its rim, where the ridge is shallow, does not decide),
    # within half a voxel whether the wall is an odd or an even number of voxels across.
    thinnest = np.maximum(2 * np.asarray(ndimage.median(inside[centres], parts[centres], index), float).reshape(-1) - 0.5 * vox, 0.0)
    del inside
    report.grown_mm = _ridge_reach(spacing, radius)
    growth = _Growth(mask, parts, centres, boxes, spacing, radius, thinnest)
    bad = growth.grow(range(1, n + 1))
    merging = _merging_parts(mask, parts, growth.owner, n)
    if merging:  # grown again without them, so the overlap of their growth with another's is that one's again
        bad |= merging | growth.grow([i for i in range(1, n + 1) if i not in bad and i not in merging])
    grow_field = growth.field
    del growth, centres
    out = mask | (grow_field >= 0)
    cavities = ndimage.binary_fill_holes(out, structure=_structure()) & ~out  # growth that closed a pocket: filled too
    if cavities.any():
        grow_field[cavities] = np.float32(vox)
        out |= cavities
    report.grow_field = grow_field
    before = report.components
    after = int(ndimage.label(out, structure=_structure())[1])
    report.joined = max(before - after, 0)
    report.components = after
    report.thin_left = [ThinRegion(_box_mm(_moved(boxes[i - 1], offset), spacing, shape), float(thinnest[i - 1]), why)
                        for i, why in sorted(bad.items(), key=lambda kv: thinnest[kv[0] - 1])]
    report.thin_grown = n - len(report.thin_left)
    return out


def _ridge_reach(spacing: np.ndarray, radius: float) -> float:
    """The radius of the balls a thin part grows on its ridge (mm): the wall's, and a quarter voxel spare."""
    return radius + 0.25 * float(spacing.max())


def _growth_pad(spacing: np.ndarray, radius: float) -> int:
    """Voxels around a thin part's box that its growth (and the neighbourhood its Euler number is counted in) may reach."""
    return int(np.ceil((radius + float(spacing.max())) / float(spacing.min()))) + 3


class _Growth:
    """The thin parts' growth, part by part in its own box: `field` (mm, ≥ 0 where grown) and
    `owner` (the part each grown voxel grew from)."""

    def __init__(self, mask, parts, centres, boxes, spacing, radius: float, thinnest):
        self.mask, self.parts, self.centres, self.boxes = mask, parts, centres, boxes
        self.spacing, self.radius, self.thinnest = spacing, radius, thinnest
        self.reach = _ridge_reach(spacing, radius)
        self.pad = _growth_pad(spacing, radius)
        self.field = self.owner = None

    def grow(self, which) -> dict[int, str]:
        """Grow the parts `which` (afresh); the parts left as they are because growing one alone
        changes the Euler number of its neighbourhood (closes a hole or a pocket)."""
        from scipy import ndimage
        from skimage.measure import euler_number

        vox = float(self.spacing.max())
        self.field = np.full(self.mask.shape, -np.float32(self.reach), np.float32)
        self.owner = np.zeros(self.mask.shape, np.int32)
        bad: dict[int, str] = {}
        for i in which:
            box = tuple(slice(max(b.start - self.pad, 0), min(b.stop + self.pad, n))
                        for b, n in zip(self.boxes[i - 1], self.mask.shape))
            part = self.parts[box] == i
            ridge = part & self.centres[box]
            # Balls of the wall's radius on the ridge, and the whole part grown by what its wall lacks: the
            # second fills between ridge voxels the first leaves apart (a ridge is a voxel's guess).
            lack = max(self.radius - self.thinnest[i - 1] / 2, 0.0) + 0.75 * vox
            field = np.maximum(self.reach - ndimage.distance_transform_edt(~ridge, sampling=self.spacing),
                               lack - ndimage.distance_transform_edt(~part, sampling=self.spacing)).astype(np.float32)
            m = self.mask[box]
            grown = (field >= 0) & ~m
            if euler_number(m | grown, connectivity=1) != euler_number(m, connectivity=1):
                bad[i] = "closes a hole or a pocket"
                continue
            here, owner = self.field[box], self.owner[box]
            take = field > here
            owner[take & grown] = i
            np.copyto(here, field, where=take)
        return bad


def _merging_parts(mask, parts, owner_part, n) -> dict[int, str]:
    """The thin parts whose growth would touch a part of the model that is apart from their own."""
    from scipy import ndimage

    old, _ = ndimage.label(mask, structure=_structure())
    part_old = np.zeros(n + 1, dtype=old.dtype)
    where = parts > 0
    found = ndimage.maximum(old[where], parts[where], np.arange(1, n + 1))
    part_old[1:] = np.asarray(found, dtype=old.dtype).reshape(-1)
    owner = old
    grow = owner_part > 0
    owner[grow] = part_old[owner_part[grow]]
    bad: set[int] = set()
    for axis in range(3):
        a = np.moveaxis(owner, axis, 0)
        g = np.moveaxis(owner_part, axis, 0)
        clash = (a[:-1] > 0) & (a[1:] > 0) & (a[:-1] != a[1:])
        bad.update(np.unique(g[:-1][clash]).tolist())
        bad.update(np.unique(g[1:][clash]).tolist())
    bad.discard(0)
    return {int(i): "joins parts that are apart" for i in bad}


def _moved(box, offset) -> tuple[slice, ...]:
    return tuple(slice(b.start + o, b.stop + o) for b, o in zip(box, offset))


def _box_mm(box, spacing, shape) -> tuple[float, ...]:
    """A (z, y, x) slice box as (x0, y0, z0, x1, y1, z1) in print mm, in the model's orientation."""
    (z, y, x), (dz, dy, dx) = box, spacing
    ny = shape[1]
    return (x.start * dx, (ny - y.stop) * dy, z.start * dz, (x.stop - 1) * dx, (ny - 1 - y.start) * dy, (z.stop - 1) * dz)


def surface_field(values: np.ndarray, level: float, filled: np.ndarray, *, report: MaskReport, spacing_mm) -> np.ndarray:
    """A float32 field, positive inside, whose zero is the model's surface (see the module's notes).

    Where the mask `filled` (from `solid_mask`, before thickening) follows the data, the field is
    (values − level) scaled to −1…1, so marching cubes puts the surface where the values cross the
    level, between voxels. Filled voids count as inside, dropped specks as outside, and where
    `thicken` grew walls the field reaches to its distance.
    """
    lo, hi = float(values.min()), float(values.max())
    scale = np.float32(max(hi - level, level - lo, 1e-30))
    out = (values - np.float32(level)) / scale
    above = out > 0
    out[filled & ~above] = 0.5  # filled voids
    out[~filled & above] = -0.5  # dropped specks
    del above
    if report.grow_field is not None:
        grown = np.clip(report.grow_field / np.float32(max(spacing_mm)), -1, 1)
        np.maximum(out, grown, out=out)
    return out


def isosurface(field_: np.ndarray, spacing_mm) -> Mesh:
    """The zero surface of `field_` (positive inside) by marching cubes: closed, wound outward, in mm.

    x = column, y = (rows − 1 − row) (row 0 at the far edge), z = slice.
    """
    from skimage.measure import marching_cubes

    spacing = tuple(float(s) for s in spacing_mm)
    padded = np.pad(field_, PAD_VOXELS, constant_values=-1.0)
    # Values at a hair's breadth from the level put a vertex on a voxel corner and leave slivers of no
    # area: nudged off it (by 1 % of the field's range, a hundredth of a voxel at most).
    near = np.abs(padded) < NUDGE
    padded[near] = np.where(padded[near] < 0, -NUDGE, NUDGE)
    del near
    verts, faces, _, _ = marching_cubes(padded, 0.0, spacing=spacing, allow_degenerate=False)
    del padded
    ny = field_.shape[1]
    out = np.empty_like(verts, dtype=np.float64)
    out[:, 0] = verts[:, 2] - PAD_VOXELS * spacing[2]
    out[:, 1] = (ny - 1 + PAD_VOXELS) * spacing[1] - verts[:, 1]
    out[:, 2] = verts[:, 0] - PAD_VOXELS * spacing[0]
    faces = faces.astype(INDEX)
    mesh = Mesh(out, faces)
    if mesh.volume_mm3() < 0:  # the y flip mirrors: wind the other way
        mesh = Mesh(out, faces[:, ::-1].copy())
    return mesh


def downsample_mask(mask: np.ndarray, factor: int) -> np.ndarray:
    """The mask on a grid `factor` times coarser (a voxel is set when half its block is)."""
    if factor <= 1:
        return mask
    shape = [-(-n // factor) * factor for n in mask.shape]
    padded = np.zeros(shape, dtype=np.float32)
    padded[: mask.shape[0], : mask.shape[1], : mask.shape[2]] = mask
    blocks = padded.reshape(shape[0] // factor, factor, shape[1] // factor, factor, shape[2] // factor, factor)
    return blocks.mean(axis=(1, 3, 5)) >= 0.5


# The most triangles scikit-image's marching cubes (Lewiner's, with its tests of ambiguous faces and
# interiors) makes in one cell, by the cell's case: bit k set when corner (k >> 2 & 1, k >> 1 & 1,
# k & 1) (z, y, x) lies inside. Found by meshing each case alone with 300 sets of corner values
# (tests/mesh/test_volume_price.py checks the bound on noise and on shapes).
CELL_TRIANGLES = np.frombuffer(bytes.fromhex(
    "0001010201020403010402030203030201020403040309040605050405040803010402030605050404090304050804030203030205040803"
    "050804030809090201040605020305040409050803040403020305040302080305080809040309020409050805080805090c080908090504"
    "03040403040305020809050405040601010604050405090802050304030404030405090809080c0905080805080509040205030405080809"
    "03080203040903020304040308050904040503020506040102050508030408090308040902030302030408050403090404050506030204"
    "010308040504050506040903040304020102030302030204010304020102010100"), dtype=np.uint8)


def surface_triangles(inside: np.ndarray) -> int:
    """The most triangles marching cubes can make of the surface of `inside` (a boolean grid, padded
    with outside as `isosurface` pads it): each cell's case, counted plane by plane (a few bytes a
    voxel at a time), priced by CELL_TRIANGLES. About 2 a cell the surface crosses on a smooth
    surface (the count marching cubes makes), up to 12 on noise."""
    nz, ny, nx = inside.shape
    plane = np.zeros((ny + 2, nx + 2), dtype=bool)
    total = 0
    below = plane.copy()  # the outside layer under the grid
    for z in range(nz + 1):
        above = np.zeros_like(plane)
        if z < nz:
            above[1:-1, 1:-1] = inside[z]
        case = np.zeros((ny + 1, nx + 1), dtype=np.uint8)
        for k in range(8):
            layer = above if k >> 2 & 1 else below
            dy, dx = k >> 1 & 1, k & 1
            case |= layer[dy:dy + ny + 1, dx:dx + nx + 1].astype(np.uint8) << k
        total += int(CELL_TRIANGLES[case].sum(dtype=np.int64))
        below = above
    return total
