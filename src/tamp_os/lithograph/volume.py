"""A z-stack or density map as a 3-D tactile model (issue 36): `make_volume` and `convert_volume`.

The steps, each in the stage that owns it:

1. read (read/volume.py): the stack's size and voxel size from its header (the first slice is read
   as a Picture, so the scale comes from the same places as a relief's: ImageJ, OME, vendor headers);
   the working grid is chosen so the volume fits `max_memory_gb` (priced before any slice is read),
   and the planes are block-averaged to it as they are read;
2. voxels (mesh/volume.py): level (Otsu, or `iso_level`), specks dropped, internal voids filled,
   walls thinner than `min_wall_mm` thickened; a coarse stack is interpolated up to a finer grid
   first (at most MAX_GROWTH times its own voxels, so the cost follows the data, not `size_mm`),
   so the surface is smooth rather than a staircase of voxels;
3. surface: marching cubes, scaled so the model's longest side is `size_mm` exactly, then simplified
   to `max_triangles` (mesh/budget.py) within 0.1 mm, the deviation measured afterwards;
4. stand (tactile/stand.py): the model on a base with the braille caption, scale bar and cut
   corner, fused; floating parts held up by posts;
5. written through the exporters like every print (checked as written first), with a description
   and a recipe (NAME.tamp.json).
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError, ParameterError, Text
from ..mesh.solid import Mesh
from ..params import LithoParams
from .report import fitted_line
from .volume_price import BYTES_PER_WORKING_VOXEL, SAY_AFTER_S, VolumePrice, price_model

log = logging.getLogger(__name__)

MAX_WORKING_VOXELS = 8_000_000  # the working grid's cap (200³): its voxel steps need ~0.5 GB
MAX_ANISOTROPY = 100.0  # voxels longer than this many times their width one way make no model (a unit slip in `z_step`)
FINEST_PITCH_MM = 0.4  # a coarse stack is interpolated up to about this voxel size on the print (a nozzle's width), never finer
MAX_GROWTH = 8.0  # ... and to at most this many times its own voxels (twice along each axis): cost follows the data, not `size_mm`
MAX_DEVIATION_MM = 0.1
SMOOTH_VOXELS = 0.5  # Gaussian sigma on the working grid before the level: noise of a voxel does not become a bump
SPECK_MM3 = 1.0  # parts smaller than a 1 mm cube are noise to a finger: dropped
WALL_SAMPLES = 5000
RESIN_WORDS = ("resin", "sla", "msla", "dlp", "lcd")
FDM_WALL_MM, RESIN_WALL_MM = 1.0, 0.6
COARSER = (1.5, 2.0)  # coarser working grids tried (besides simplifying alone) when the budget cannot hold within 0.1 mm


@dataclass
class VolumeModel:
    """A 3-D model made from a stack: the solid, the bare model, and what was measured."""

    mesh: Mesh  # what is written (on its base unless `volume_stand` is none)
    model: Mesh  # the bare model, its lowest point at z = 0, its longest side `size_mm`
    params: LithoParams
    name: str
    path: str | None
    sha256: str
    format: str
    source_shape: tuple[int, int, int]  # z, y, x
    working_shape: tuple[int, int, int]
    voxel_m: tuple[float, float, float] | None  # z, y, x in the sample; None when unknown
    pitch_mm: tuple[float, float, float]  # the working voxel on the print, z, y, x
    size_mm: tuple[float, float, float]  # the model's x, y, z extent
    level: float
    level_from: str
    specks_dropped: int
    voids_filled: int
    parts: int
    genus: int
    triangles_full: int
    triangles: int
    deviation_mm: float
    tolerance_mm: float
    budget_met: bool
    min_wall_mm: float
    wall_p1_mm: float  # the 1st percentile of the sampled walls
    wall_wanted_mm: float
    thickened_mm: float
    thin_voxels: int
    joined: int
    thin_regions_mm: list
    floating: int = 0  # parts that do not reach the base
    posts: int = 0  # of those, held up by a post
    plate_mm: tuple[float, float] | None = None
    scale_label: str | None = None
    caption_braille: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0
    sample_m_per_mm: float | None = None  # the sample length one millimetre of the model stands for
    thin_left: list = field(default_factory=list)  # mesh.volume.ThinRegion: thin parts not thickened (where, how thin, why)
    thin_grown: int = 0  # thin parts thickened to the wall
    coarsened: float = 1.0  # the working grid made this many times coarser to meet the triangle budget
    price: VolumePrice | None = None  # what the model was priced at before the voxel steps


def min_wall_for(params: LithoParams, printer_name: str, printer_description: str) -> float:
    """`min_wall_mm`, or 1.0 mm for FDM and 0.6 mm for a resin printer (by its profile's name and words)."""
    if params.min_wall_mm is not None:
        return float(params.min_wall_mm)
    words = f"{printer_name} {printer_description}".lower()
    return RESIN_WALL_MM if any(w in words for w in RESIN_WORDS) else FDM_WALL_MM


def _voxel_size(picture, params: LithoParams, notes: list[str], warnings: list[str]):
    """(z, y, x) voxel size in metres from the file (or the user), or None when unknown."""
    from ..clean.scale import read_pixel_size

    f = picture.file
    vendor = (f.metadata or {}).get("vendor") or {}
    size = read_pixel_size(f.metadata, f.tiff_tags, f.path, width_px=f.width, pixel_size_m=params.pixel_size_m)
    warnings.extend(size.warnings)
    xy = None
    if params.pixel_size_m is None and vendor.get("pixel_size_m"):
        x, y = vendor["pixel_size_m"]
        xy = (float(y), float(x))
    elif size.metres:
        xy = (float(size.metres), float(size.metres))
    z = params.z_step_m or f.z_step_m
    from ..units import format_length

    if xy is None:
        notes.append(Text("the voxel size is not known (give `pixel_size` and `z_step`): the voxels are shown as cubes and "
                          "the model has no scale bar."))
        return None
    if z is None:
        warnings.append(Text(f"the z step is not known: taken equal to the pixel size, {format_length(xy[1])} (give `z_step`)."))
        z = xy[1]
    return (float(z), xy[0], xy[1])


def _check_anisotropy(path, voxel_m, shape, params: LithoParams) -> None:
    """Refuse voxels more than MAX_ANISOTROPY times longer one way than another: no surface can be
    made of them (the model would be a sheet or a needle thinner than a wall), and the grid padded
    to hold a wall in the short voxels' units would be vast. Almost always a unit slip."""
    if not voxel_m:
        return
    z, y, x = voxel_m
    ratio = max(voxel_m) / min(voxel_m)
    if ratio <= MAX_ANISOTROPY:
        return
    from ..units import format_length

    nz, ny, nx = shape
    extent = np.asarray([nz * z, ny * y, nx * x])
    size = float(params.size_mm or 100.0)
    x_mm, y_mm, z_mm = (float(e) * size / float(extent.max()) for e in extent[::-1])
    given = "the z step you gave" if params.z_step_m else "the file's z step"
    raise ParameterError(
        f"{path}: the voxels are {ratio:,.0f} times longer one way than another (z step {format_length(z)}, pixel "
        f"{format_length(x)}); a 3-D model needs voxels within {MAX_ANISOTROPY:g} times of each other (this one would be "
        f"{x_mm:.3g} × {y_mm:.3g} × {z_mm:.3g} mm). Check `z_step` ({given}) and `pixel_size`.",
        parameter="z_step", value=z, allowed=f"within {MAX_ANISOTROPY:g} times the pixel size")


def _working_grid(shape, voxel_rel, budget_voxels: int):
    """Whole reduction factors (z, y, x) so the reduced stack has at most `budget_voxels`, coarsening
    the finest axes (in the sample) first."""
    nz, ny, nx = shape
    steps = np.asarray(voxel_rel, dtype=float)
    pitch = float(steps.min())
    for _ in range(200):
        factors = [max(1, int(math.floor(pitch / s + 1e-9))) for s in steps]
        count = math.prod(-(-n // f) for n, f in zip(shape, factors))
        if count <= budget_voxels:
            return tuple(factors)
        pitch *= 1.1
    return tuple(max(1, n // 2) for n in (nz, ny, nx))


def make_volume(source, params: LithoParams | None = None, *, printer=None, on_price=None) -> VolumeModel:
    """The 3-D model of the stack in `source` (a file of any format the readers read).

    The whole model is priced (volume_price.py) once the working grid is known, before the voxel
    steps: a price over `max_memory_gb` is refused (InputError, nothing made), and `on_price`, when
    given, is called with the VolumePrice before the work goes on (the CLI says a long one's time).
    """
    from ..mesh import budget as mb
    from ..mesh import volume as mv
    from ..read.cost import Cost, check_memory
    from ..read.image import read_image
    from ..read.model import Limits
    from ..read.volume import open_stack_shape, read_volume
    from .sizing import resolve_printer

    start = time.perf_counter()
    params = params or LithoParams(volume=True)
    path = Path(source)
    printer = printer or resolve_printer(params)
    notes: list[str] = []
    warnings: list[str] = []
    limits = Limits(params.max_megapixels, params.max_decoded_gb, params.max_memory_gb)
    picture = read_image(path, **params.read_options(z_slice=0, page=None))  # its first plane: the stack's size
    nz = int(picture.file.axes.get("Z", 1))
    if nz < 2:
        raise InputError(f"{path}: holds a single plane ({picture.file.width}×{picture.file.height} pixels, no z axis); `volume` "
                         f"needs a z-stack of at least 2 slices. Convert it as a relief (leave `volume` out), or export the "
                         f"whole stack from the microscope software.")
    voxel_m = _voxel_size(picture, params, notes, warnings)
    _check_anisotropy(path, voxel_m, (nz, picture.file.height, picture.file.width), params)
    shape = open_stack_shape(path, channel=params.channel, time=params.time, scene=params.scene, limits=limits)
    source_shape = (shape.nz, shape.ny, shape.nx)
    # The memory the voxel steps need, priced before any slice is read: the working grid is chosen to fit.
    budget_voxels = int(min(MAX_WORKING_VOXELS, params.max_memory_gb * 1e9 * 0.8 / BYTES_PER_WORKING_VOXEL))
    rel = voxel_m if voxel_m else (1.0, 1.0, 1.0)
    factors = _working_grid(source_shape, rel, budget_voxels)
    cost = Cost()
    cost.add("one slice decoded", float(shape.ny) * shape.nx * (shape.dtype.itemsize + 4))
    reduced = math.prod(-(-n // f) for n, f in zip(source_shape, factors))
    cost.add("the working grid's voxel steps", float(reduced) * BYTES_PER_WORKING_VOXEL)
    check_memory(path, f"{shape.nx}×{shape.ny}×{shape.nz} stack", cost, max_memory_gb=params.max_memory_gb)
    try:
        read = read_volume(shape, factors, path)
    except MemoryError:
        raise InputError(f"{path}: not enough memory to read this stack; lower `max_memory_gb` so it is read coarser.") from None
    notes += read.notes
    if any(f > 1 for f in factors):
        notes.append(f"the stack ({shape.nx}×{shape.ny}×{shape.nz} voxels) was averaged over blocks of "
                     f"{factors[2]}×{factors[1]}×{factors[0]} voxels to fit the working grid.")
    try:
        return _model(path, picture, params, printer, read, voxel_m, rel, factors, budget_voxels, notes, warnings, start, mv, mb,
                      on_price)
    except MemoryError:
        raise InputError(f"{path}: not enough memory to mesh this stack; lower `max_memory_gb` (the stack is then read on a "
                         f"coarser grid) or `size_mm`.") from None


@dataclass
class _Grid:
    """The working voxels, cropped to the content: values, their voxel on the print (mm), the scale."""

    values: np.ndarray
    pitch: np.ndarray  # z, y, x, print mm
    scale: float  # print mm per sample unit (m, or source voxels when the size is unknown)
    lo: float
    hi: float
    level: float
    level_from: str


@dataclass
class _Surface:
    """The model's surface as kept, and what keeping it cost."""

    solid: object  # manifold3d.Manifold
    model: Mesh
    budget: object  # mesh.budget.Budget
    coarsened: float = 1.0  # the working grid was made this many times coarser to meet the budget
    rescale: float = 1.0  # the surface was scaled by this to its exact size (walls grown past the object's extent)
    origin: np.ndarray | None = None  # the grid's point (x, y, z mm) that became the model's lowest corner
    full: Mesh | None = None  # the full-resolution surface, the deviation's reference

    def on_model(self, region):
        """A ThinRegion from the working grid's millimetres to the model's."""
        import dataclasses

        o = np.zeros(3) if self.origin is None else self.origin
        box = [(b - o[i % 3]) * self.rescale for i, b in enumerate(region.box_mm)]
        return dataclasses.replace(region, box_mm=tuple(float(b) for b in box), thinnest_mm=region.thinnest_mm * self.rescale)


def _model(path, picture, params, printer, read, voxel_m, rel, factors, budget_voxels, notes, warnings, start, mv, mb,
           on_price=None) -> VolumeModel:
    """The model from the read stack: level, voxels, surface within the budget, walls, stand."""
    size_mm = float(params.size_mm or printer.width_mm)
    grid = _content_grid(path, read.values, params, rel, factors, size_mm, budget_voxels, mv)
    wall = min_wall_for(params, printer.name, printer.description)
    # Background around the grid: a part cut by the stack's edge has a face there, and its walls can grow past it.
    pad = wall_pad(grid.pitch, wall)
    grid.values = np.pad(grid.values, [(p, p) for p in pad], mode="constant", constant_values=np.float32(grid.lo))
    price = _priced(path, grid, params, mv, notes, on_price)
    filled, report = mv.solid_mask(grid.values, grid.level, tuple(grid.pitch), speck_mm3=SPECK_MM3)
    if not report.voxels:
        raise InputError(f"{path}: no part of the stack above `iso_level` {grid.level:g} is larger than {SPECK_MM3:g} mm³ on the "
                         f"model; choose a lower `iso_level` (the stack's values run from {grid.lo:g} to {grid.hi:g}) or a larger "
                         f"`size_mm`.")
    mv.thicken(filled, tuple(grid.pitch), wall, report=report)
    working_shape = tuple(int(n_) for n_ in filled.shape)
    field_ = mv.surface_field(grid.values, grid.level, filled, report=report, spacing_mm=tuple(grid.pitch))
    del filled
    grid.values = None
    report.grow_field = None
    surface = _surface_within_budget(path, field_, grid, size_mm, params, mv, mb,
                                     room=(lambda x, y: _stand_room(path, params, x, y, None if voxel_m is None else 1.0 / grid.scale))
                                     if params.volume_stand == "plate" else None)
    del field_
    warnings.extend(_surface_warnings(surface, params))
    points, normals = mb.sample_surface(surface.model, WALL_SAMPLES, seed=3)
    walls = mb.wall_thickness(surface.solid, points, normals, reach_mm=size_mm)
    pieces = surface.solid.decompose()
    report.thin_left = [surface.on_model(r) for r in report.thin_left]
    warnings.extend(_wall_warnings(report, walls, wall))
    model = surface.model
    x, y, z = (float(v) for v in (model.vertices.max(axis=0) - model.vertices.min(axis=0)))
    per_mm = None if voxel_m is None else 1.0 / (grid.scale * surface.rescale)  # sample metres per print mm
    budget = surface.budget
    out = VolumeModel(
        mesh=model, model=model, params=params, name=path.name, path=str(path), sha256=picture.file.sha256,
        format=read.format, source_shape=read.source_shape, working_shape=working_shape, voxel_m=voxel_m,
        pitch_mm=tuple(float(p) for p in grid.pitch), size_mm=(x, y, z), level=grid.level, level_from=grid.level_from,
        specks_dropped=report.specks_dropped, voids_filled=report.voids_filled, parts=len(pieces),
        genus=sum(int(p.genus()) for p in pieces), triangles_full=budget.triangles_before, triangles=budget.triangles,
        deviation_mm=budget.deviation_mm, tolerance_mm=budget.tolerance_mm, budget_met=budget.met, min_wall_mm=float(walls.min()),
        wall_p1_mm=float(np.percentile(walls, 1)), wall_wanted_mm=wall, thickened_mm=report.grown_mm,
        thin_voxels=report.thin_voxels, joined=report.joined, thin_regions_mm=report.thin_regions_mm,
        notes=notes, warnings=warnings, sample_m_per_mm=per_mm, thin_left=list(report.thin_left),
        thin_grown=report.thin_grown, coarsened=surface.coarsened, price=price,
    )
    if params.volume_stand == "plate":
        _stand(out, path, surface, params, per_mm)
    else:
        from ..mesh.repair import as_written

        out.mesh = as_written(model)  # the bare model, repaired of faces of no area where needed
    if per_mm:
        from ..units import format_length

        notes.append(f"1 mm on the model = {format_length(per_mm)} of the sample.")
    out.seconds = time.perf_counter() - start
    return out


def _priced(path, grid: _Grid, params, mv, notes: list[str], on_price) -> VolumePrice:
    """The whole model priced from the padded working grid and its surface's triangle bound: refused
    over `max_memory_gb`, a long one's time noted and passed to `on_price`."""
    price = price_model(grid.values.size, mv.surface_triangles(grid.values > grid.level), params.max_triangles)
    log.info("priced: %s", price.words())
    price.check(path, max_memory_gb=params.max_memory_gb, hint="A higher `iso_level` makes a smaller surface of a noisy stack.")
    if price.seconds >= SAY_AFTER_S:
        notes.append(f"priced before the work at {price.words()}.")
    if on_price is not None:
        on_price(price)
    return price


def _level(path, values, params, mv) -> tuple[float, str, float, float]:
    """(level, where it came from, the stack's lowest and highest values); a blank stack or a level
    outside the values refused."""
    lo, hi = float(values.min()), float(values.max())
    if lo == hi:
        raise InputError(f"{path}: the stack is blank: every voxel is {lo:g}, so there is no surface to model. Check the "
                         f"channel (`channel`) and time point (`time`).")
    level_from = "given" if params.iso_level is not None else "Otsu"
    level = float(params.iso_level) if params.iso_level is not None else mv.otsu_level(values)
    if not lo <= level < hi:
        raise ParameterError(f"{path}: `iso_level` must lie within the stack's values, {lo:g} to {hi:g} (below its largest "
                             f"value, so some voxels lie above it); got {level:g}. Leave it out for Otsu's level.",
                             parameter="iso_level", value=level, allowed=f"{lo:g} to {hi:g}")
    return level, level_from, lo, hi


def _content_grid(path, values, params, rel, factors, size_mm, budget_voxels, mv) -> _Grid:
    """The working values cropped to what is left once specks are dropped (which sets the model's
    extent and scale), interpolated up towards FINEST_PITCH_MM and smoothed."""
    from scipy import ndimage

    level, level_from, lo, hi = _level(path, values, params, mv)
    step = np.asarray(rel, dtype=float) * np.asarray(factors, dtype=float)  # working voxel, sample units (m, or voxels)
    # Specks, at the scale of the whole stack (the model is at least this large): what is left sets the model's extent.
    provisional = size_mm / float((np.asarray(values.shape) * step).max())
    labels, n = ndimage.label(values > level)
    sizes = np.bincount(labels.ravel())[1:] * float(np.prod(step * provisional))
    keep = np.flatnonzero(sizes >= SPECK_MM3) + 1
    if keep.size == 0:
        biggest = float(sizes.max()) if sizes.size else 0.0
        raise InputError(f"{path}: above `iso_level` {level:g} the stack holds only specks ({n} parts, the largest "
                         f"{biggest:.2g} mm³ at this size, each smaller than {SPECK_MM3:g} mm³), nothing a hand can find; choose a "
                         f"lower `iso_level` (the stack's values run from {lo:g} to {hi:g}) or a larger `size_mm`.")
    kept = np.isin(labels, keep)
    del labels
    box = ndimage.find_objects(kept.astype(np.int8))[0]
    box = tuple(slice(max(b.start - 3, 0), min(b.stop + 3, n_)) for b, n_ in zip(box, values.shape))  # room for the smoothing
    margin = ndimage.binary_dilation(kept[box], iterations=2)
    cropped = np.where(margin, values[box], np.float32(lo)).astype(np.float32)
    del margin
    inner = ndimage.find_objects(kept[box].astype(np.int8))[0]
    extent = np.asarray([b.stop - b.start for b in inner], dtype=float) * step  # z, y, x in sample units: the object's own
    del kept
    scale = size_mm / float(extent.max())  # print mm per sample unit
    cropped, pitch = _refined(cropped, step * scale, budget_voxels, averaged=np.asarray(factors) > 1)
    return _Grid(cropped, pitch, scale, lo, hi, level, level_from)


def refine_zoom(pitch_mm, shape, budget_voxels: int) -> np.ndarray:
    """The zoom (z, y, x, ≥ 1, in quarter steps) that interpolates a grid of `shape` voxels of
    `pitch_mm` towards FINEST_PITCH_MM, at most MAX_GROWTH times its own voxel count (and within
    `budget_voxels`): the coarsest axes first, so an anisotropic stack grows along its long voxels
    and its surface is made near the data's own resolution, not at the print's.

    The finest common pitch t ≥ FINEST_PITCH_MM whose zoom max(1, pitch / t) stays within the
    growth is found by bisection; the zoom is then rounded down to quarter steps.
    """
    pitch = np.asarray(pitch_mm, dtype=float)
    voxels = float(np.prod(np.asarray(shape, dtype=float)))
    growth = min(MAX_GROWTH, max(1.0, budget_voxels / max(voxels, 1.0)))

    def grown(t: float) -> float:
        return float(np.prod(np.maximum(1.0, pitch / t)))

    lo, hi = FINEST_PITCH_MM, max(float(pitch.max()), FINEST_PITCH_MM)
    if grown(lo) > growth:
        for _ in range(40):
            middle = math.sqrt(lo * hi)
            lo, hi = (middle, hi) if grown(middle) > growth else (lo, middle)
        lo = hi
    zoom = np.maximum(1.0, pitch / lo)
    return np.maximum(1.0, np.floor(zoom * 4 + 1e-9) / 4)


def _refined(values: np.ndarray, pitch: np.ndarray, budget_voxels: int, averaged=None) -> tuple[np.ndarray, np.ndarray]:
    """A coarse grid interpolated up (linear, `refine_zoom`), so the surface is smooth rather than
    a staircase of voxels, then smoothed by SMOOTH_VOXELS: (values, their pitch on the print).
    An axis the stack was `averaged` down along (to fit the voxel budget) is not interpolated up again."""
    from scipy import ndimage

    zoom = refine_zoom(pitch, values.shape, budget_voxels)
    if averaged is not None:
        zoom = np.where(averaged, 1.0, zoom)
    if (zoom > 1).any():
        values = ndimage.zoom(values, zoom, order=1, mode="nearest", grid_mode=True)
        pitch = pitch / zoom
    if SMOOTH_VOXELS:
        values = ndimage.gaussian_filter(values, SMOOTH_VOXELS, mode="nearest")
    return values, pitch


def wall_pad(pitch_mm, wall_mm: float) -> tuple[int, int, int]:
    """Background voxels around the grid along each axis (z, y, x): a part cut by the stack's edge
    has a face there, and its walls can grow past it by half a wall and a voxel."""
    pitch = np.asarray(pitch_mm, dtype=float)
    reach = wall_mm / 2 + float(pitch.max())
    return tuple(int(np.ceil(reach / float(p))) + 1 for p in pitch)


def _closed(path, mesh: Mesh, level: float, mb):
    """The mesh as a manifold3d solid; InputError when it cannot be one."""
    import manifold3d as m3

    solid = mb.to_manifold(mesh)
    if solid.status() != m3.Error.NoError:
        raise InputError(f"{path}: the isosurface at `iso_level` {level:g} could not be made a closed solid "
                         f"({solid.status()}); try another `iso_level` or a smaller `size_mm`, and please report this stack.")
    return solid


def _surface_within_budget(path, field_, grid: _Grid, size_mm: float, params, mv, mb, room=None) -> _Surface:
    """The surface simplified to `max_triangles` within MAX_DEVIATION_MM of the full-resolution one.

    When that cannot be (the simplification that meets the budget moves the surface further), the
    budget is kept the way that moves it least, by measurement: the full surface simplified to the
    budget, or, when that moves it more than twice the limit, meshed again on grids COARSER times
    coarser (simplified to the budget if still over it), each measured against the full surface; the
    deviation is reported. Only when none meets the budget is the surface kept within the limit.

    `room(width_mm, depth_mm)`, when given, is what the base and its furniture will add: the surface
    is simplified to the budget less that, once (the stand then rarely needs a second pass).
    """
    raw = mv.isosurface(field_, tuple(grid.pitch))
    rescale = size_mm / float((raw.vertices.max(axis=0) - raw.vertices.min(axis=0)).max())
    origin = raw.vertices.min(axis=0)
    full = _exact_size(raw, size_mm)
    del raw
    most = params.max_triangles
    if room is not None and full.n_triangles > most:
        x, y = (float(v) for v in (full.vertices.max(axis=0) - full.vertices.min(axis=0))[:2])
        extra = room(x, y)
        if 2 * extra < most:  # else the base alone takes the budget: the stand says so
            most -= extra
    surface = _budgeted(path, field_, grid, full, size_mm, params, mv, mb, most=most)
    surface.rescale, surface.origin, surface.full = rescale, origin, full
    return surface


def _budgeted(path, field_, grid: _Grid, full: Mesh, size_mm: float, params, mv, mb, *, most: int) -> _Surface:
    """`_surface_within_budget` once the full surface is made (see there), to `most` triangles."""
    solid = _closed(path, full, grid.level, mb)
    before, limit = int(solid.num_tri()), MAX_DEVIATION_MM
    if before <= most:
        return _Surface(solid, mb.from_manifold(solid), mb.Budget(before, before, 0.0, True))
    candidate, tolerance, measured = mb.simplify_to_budget(solid, most, full, start_mm=limit)
    best = None
    if candidate.num_tri() <= most:
        best = _Surface(candidate, mb.from_manifold(candidate), mb.Budget(before, int(candidate.num_tri()), tolerance, True,
                                                                          measured, within=measured <= limit))
    for factor in COARSER if best is None or measured > 2 * limit else ():
        coarse = _closed(path, _coarse_mesh(field_, grid.pitch, factor, size_mm, mv), grid.level, mb)
        tolerance = mb.tolerance_for(coarse, most, limit) if coarse.num_tri() > most else 0.0
        coarse = coarse.simplify(tolerance) if tolerance else coarse
        if coarse.num_tri() > most:
            continue
        mesh = mb.from_manifold(coarse)
        measured = mb.surface_deviation(full, mesh)
        log.info("budget by a %g times coarser grid and tolerance %.3f mm: %d triangles, %.3f mm from the full surface",
                 factor, tolerance, coarse.num_tri(), measured)
        if best is None or measured < best.budget.deviation_mm:
            best = _Surface(coarse, mesh, mb.Budget(before, int(coarse.num_tri()), tolerance, True, measured,
                                                    within=measured <= limit), factor)
    if best is not None:
        return best
    kept, tolerance, measured = mb.largest_within(solid, full, limit, max_deviation_mm=limit)
    return _Surface(kept, mb.from_manifold(kept), mb.Budget(before, int(kept.num_tri()), tolerance, False, measured))


def _coarse_mesh(field_, pitch, factor: float, size_mm: float, mv) -> Mesh:
    """The field's surface meshed on a grid `factor` times coarser, at the model's size."""
    from scipy import ndimage

    coarse = ndimage.zoom(field_, 1 / factor, order=1, mode="nearest", grid_mode=True)
    step = np.asarray(pitch) * np.asarray(field_.shape, float) / np.asarray(coarse.shape, float)
    return _exact_size(mv.isosurface(coarse, tuple(step)), size_mm)


def _surface_warnings(surface: _Surface, params) -> list[str]:
    """The one plain line when the budget and the 0.1 mm could not both hold: which was kept, the numbers."""
    b = surface.budget
    if not b.met:
        return [Text(f"the model keeps {b.triangles:,} triangles, more than `max_triangles` {params.max_triangles:,}: "
                     f"no simplification or coarser grid reached the budget, so the surface was kept within "
                     f"{MAX_DEVIATION_MM} mm ({b.deviation_mm:.3f} mm) instead. Raise `max_triangles`, or lower `size_mm`.")]
    if not b.within:
        how = f"meshed {surface.coarsened:g} times coarser" if surface.coarsened > 1 else "simplified"
        return [Text(f"the triangle budget was kept and the {MAX_DEVIATION_MM} mm was not: {b.triangles:,} triangles (at most "
                     f"`max_triangles` {params.max_triangles:,}), {how}, lie up to {b.deviation_mm:.2f} mm from the "
                     f"full-resolution surface of {b.triangles_before:,} triangles. Raise `max_triangles` for the finer surface.")]
    return []


def _wall_warnings(report, walls: np.ndarray, wall: float) -> list[str]:
    """Thin parts left thin (where, how thin, why), and walls thinner than asked where the surface bends."""
    out = []
    if report.thin_left:  # where they are (boxes of coordinates) is for the description, not a warning's line
        n = len(report.thin_left)
        thinnest = min(r.thinnest_mm for r in report.thin_left)
        out.append(Text(f"{n} thin part{'s' if n > 1 else ''} left thinner than {wall:g} mm (thinnest {thinnest:.2f} mm) not to "
                        f"change the structure; the description says where. A larger `size_mm` thickens them."))
    if report.joined:
        out.append(Text(f"thickening walls to {wall:g} mm joined {report.joined} parts that were apart; a larger `size_mm` keeps "
                        f"them apart."))
    p1 = float(np.percentile(walls, 1))
    if p1 < wall * 0.9 and not report.thin_left:
        out.append(Text(f"some walls are thinner than {wall:g} mm where the surface bends ({p1:.2f} mm at the thinnest 1 % of "
                        f"{WALL_SAMPLES:,} points); a larger `size_mm` makes them thicker."))
    return out


def _furniture(path, params, per_mm):
    from ..tactile.furniture import Furniture

    return Furniture(
        caption=params.caption if params.caption is not None else path.stem.replace("_", " ")[:60],
        braille_table=params.braille_table, scale_bar_m=params.scale_bar_m,
        auto_scale_bar=params.scale_bar == "auto", sample_m_per_print_mm=per_mm,
        corner_cut=params.orientation_corner == "cut", spec=params.braille_spec(),
    )


def _stand_room(path, params, width_mm: float, depth_mm: float, per_mm) -> int:
    """The triangles the base and its furniture will add (a tenth more, and some for the seam and posts)."""
    from ..tactile.stand import furniture_triangles

    furniture = _furniture(path, params, per_mm)
    return int(furniture_triangles(width_mm, depth_mm, base_mm=params.base_mm, furniture=furniture) * 1.1) + 1000


def _stand(out: VolumeModel, path, surface: _Surface, params, per_mm) -> None:
    """`out` on its base plate with the furniture (its mesh, plate, scale and the floating parts' note).
    The budget counts the whole file: when the base and furniture take it over `max_triangles`, the
    model is simplified further by what they need, measured again, and stood again."""
    from ..tactile.stand import stand_model

    x, y, _ = out.size_mm
    furniture = _furniture(path, params, per_mm)
    stand, out.mesh = _fused(path, surface.solid, x, y, params.base_mm, furniture, stand_model)
    extra = out.mesh.n_triangles - int(surface.solid.num_tri())
    if (out.mesh.n_triangles > params.max_triangles and surface.budget.met and surface.full is not None
            and params.max_triangles > 2 * extra):
        _leave_room(out, surface, params.max_triangles - extra)
        stand, out.mesh = _fused(path, surface.solid, x, y, params.base_mm, furniture, stand_model)
    if out.mesh.n_triangles > params.max_triangles:
        out.warnings.append(Text(f"the file has {out.mesh.n_triangles:,} triangles, over `max_triangles` {params.max_triangles:,}: "
                                 f"the base with its braille and scale bar alone takes {extra:,}. Give `max_triangles` at least "
                                 f"{2 * extra + 1:,}, or `volume_stand` none for the bare model."))
    out.floating, out.posts = stand.floating, stand.posts
    out.plate_mm = stand.placed.plate_mm
    out.scale_label = stand.placed.scale_label
    out.caption_braille = stand.placed.caption_braille
    out.notes.extend(stand.placed.notes)
    if stand.floating:
        held = (f"; {'each' if stand.posts == stand.floating else stand.posts} stands on a post 2.4 mm across"
                if stand.posts else "")
        loose = stand.floating - stand.posts
        out.notes.append(f"{stand.floating} part{'s' if stand.floating > 1 else ''} of the model do{'es' if stand.floating == 1 else ''} "
                         f"not reach the base{held}" + (f"; {loose} with other parts below {'them' if loose > 1 else 'it'} "
                         f"float{'s' if loose == 1 else ''} in the file as separate pieces (print them apart, or give "
                         f"a lower `iso_level` so they join)" if loose else "") + ".")


def _leave_room(out: VolumeModel, surface: _Surface, most: int) -> None:
    """The model simplified to at most `most` triangles (room for its base), measured against the full surface."""
    from ..mesh import budget as mb

    tolerance = mb.tolerance_for(surface.solid, most, max(surface.budget.tolerance_mm, 0.01))
    surface.solid = surface.solid.simplify(tolerance)
    surface.model = mb.from_manifold(surface.solid)
    deviation = mb.surface_deviation(surface.full, surface.model)
    out.model, out.triangles, out.deviation_mm = surface.model, int(surface.solid.num_tri()), deviation
    out.tolerance_mm = max(out.tolerance_mm, tolerance)
    points, normals = mb.sample_surface(surface.model, WALL_SAMPLES, seed=3)  # the walls of the model as written
    walls = mb.wall_thickness(surface.solid, points, normals, reach_mm=max(out.size_mm))
    out.min_wall_mm, out.wall_p1_mm = float(walls.min()), float(np.percentile(walls, 1))
    if deviation > MAX_DEVIATION_MM and not any("budget was kept" in str(w) for w in out.warnings):
        out.warnings.append(Text(f"the triangle budget was kept and the {MAX_DEVIATION_MM} mm was not: the model's "
                                 f"{out.triangles:,} triangles (its base takes the rest of `max_triangles`) lie up to "
                                 f"{deviation:.2f} mm from the full-resolution surface. Raise `max_triangles` for the finer surface."))


def _fused(path, simplified, width_mm, depth_mm, base_mm, furniture, stand_model):
    """(the Stand, its mesh as written): with posts under floating parts, or, when their union leaves
    faces of no area that cannot be repaired, without them; InputError when neither is a sound solid."""
    from ..mesh.budget import from_manifold
    from ..mesh.repair import part_pinches, remove_slivers
    from ..mesh.validate import check_as_written
    import manifold3d as m3

    problems: list[str] = []
    for posts in (True, False):
        stand = stand_model(simplified, width_mm, depth_mm, base_mm=base_mm, furniture=furniture, with_posts=posts)
        if stand.solid.status() != m3.Error.NoError:
            problems = [str(stand.solid.status())]
            continue
        raw = mesh = from_manifold(stand.solid)
        check = check_as_written(mesh)
        for repair in (remove_slivers, part_pinches, lambda m: remove_slivers(part_pinches(m))):
            if check.ok:
                break
            mesh = repair(raw)  # each repair from the solid as made (neither changes its input)
            check = check_as_written(mesh)
        if check.ok:
            return stand, mesh
        problems = check.problems
        if not stand.posts:
            break
    raise InputError(f"{path}: the model could not be fused with its base into a sound solid ({'; '.join(problems)}); write "
                     f"the bare model with `volume_stand` none, or try another `iso_level` or `size_mm`, and please report this stack.")


def _exact_size(mesh: Mesh, size_mm: float) -> Mesh:
    """The mesh moved to the origin (lowest corner at 0) and scaled so its longest side is `size_mm`."""
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    factor = size_mm / float((hi - lo).max())
    return Mesh((mesh.vertices - lo) * factor, mesh.faces)


def describe_volume(v: VolumeModel) -> str:
    """What the model shows, its size and its scale, in sentences for the description file."""
    from ..units import format_length

    x, y, z = v.size_mm
    nz, ny, nx = v.source_shape
    parts = [f"A 3-D tactile model of {v.params.subject or v.name}: the surface of a {nx} × {ny} × {nz} voxel stack "
             f"({v.format}) where its values pass {v.level:.4g} ({'Otsu' if v.level_from == 'Otsu' else 'the level given'})."]
    parts.append(f"The model is {x:.1f} mm wide, {y:.1f} mm deep and {z:.1f} mm tall; z (the stack's slices) points up, and "
                 f"seen from above it looks like the stack's maximum projection, its top row at the far edge.")
    if v.voxel_m and v.sample_m_per_mm:
        dz, dy, dx = v.voxel_m
        parts.append(f"1 mm on the model is {format_length(v.sample_m_per_mm)} of the sample (voxels {format_length(dx)} × "
                     f"{format_length(dy)} × {format_length(dz)}, z scaled as measured).")
    else:
        parts.append("The voxel size is not known: the voxels are shown as cubes, and the model has no scale.")
    joined = ""
    if v.parts > 1 and v.plate_mm:
        loose = v.floating - v.posts
        joined = (", all standing on the base" if not v.floating else
                  f", standing on the base ({v.posts} of them on posts{f'; {loose} lie loose above other parts' if loose else ''})")
    parts.append(f"It is {'one solid part' if v.parts == 1 else f'{v.parts} separate parts'}"
                 + (f" with {v.genus} hole{'s' if v.genus != 1 else ''} through {'it' if v.parts == 1 else 'them'}" if v.genus else "")
                 + joined + ".")
    if v.voids_filled:
        parts.append(f"{v.voids_filled} internal void{'s were' if v.voids_filled > 1 else ' was'} filled, since a finger cannot reach it.")
    if v.thin_grown:
        parts.append(f"Walls thinner than {v.wall_wanted_mm:g} mm were thickened to at least {v.wall_wanted_mm:g} mm "
                     f"({v.thin_grown} part{'s' if v.thin_grown != 1 else ''}).")
    if v.thin_left:
        parts.append(f"{len(v.thin_left)} thin part{'s were' if len(v.thin_left) != 1 else ' was'} left thinner than "
                     f"{v.wall_wanted_mm:g} mm, since thickening would change the structure: "
                     + "; ".join(r.words() for r in v.thin_left[:5]) + ("; …" if len(v.thin_left) > 5 else "") + ".")
    if v.budget_met and v.tolerance_mm == 0 and v.coarsened == 1:
        parts.append(f"Its surface has {v.triangles:,} triangles, the full-resolution surface.")
    elif v.deviation_mm <= MAX_DEVIATION_MM:
        parts.append(f"Its surface has {v.triangles:,} triangles, within {v.deviation_mm:.2f} mm of the full-resolution surface "
                     f"({v.triangles_full:,} triangles).")
    else:
        parts.append(f"The triangle budget was kept and the {MAX_DEVIATION_MM} mm was not: its {v.triangles:,} triangles lie up to "
                     f"{v.deviation_mm:.2f} mm from the full-resolution surface ({v.triangles_full:,} triangles).")
    if v.plate_mm:
        parts.append(f"It stands on a base plate {v.plate_mm[0]:.0f} × {v.plate_mm[1]:.0f} mm with a braille caption"
                     + (f", a scale bar of {v.scale_label}" if v.scale_label else "") + ", and the top right corner cut off.")
    return " ".join(p for p in parts if p)



@dataclass(frozen=True)
class VolumeConversion:
    """One stack converted: the model and the files written (recipe last)."""

    model: VolumeModel
    written: tuple[Path, ...]

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.written]

    def summary(self, *, say_folder: bool = True) -> str:
        """The one result line; without `say_folder` (the web app, whose folder is its own) a line too
        long for the files' names says only their count."""
        v = self.model
        x, y, z = v.size_mm
        scale = f", 1 mm = {_length_words(v.sample_m_per_mm)}" if v.sample_m_per_mm else ", scale unknown"
        surface = (f"simplified within {v.deviation_mm:.3f} mm of the full surface" if v.tolerance_mm
                   else "the full surface, not simplified")
        size = f"3-D model {x:.1f} × {y:.1f} × {z:.1f} mm{scale}"
        wall = f"thinnest wall {v.wall_p1_mm:.2f} mm"
        bodies = [f"{size}, {v.mesh.n_triangles:,} triangles ({surface}), {wall}", f"{size}, {v.mesh.n_triangles:,} triangles, {wall}",
                  f"{size}, {wall}"]
        folder = str(self.written[0].parent) if self.written and say_folder else None
        return fitted_line(v.name, bodies, self.names, folder=folder)

    def lines(self, say=str) -> list[str]:
        """The summary and the notes, as `tamp-os convert` prints them; `say` puts a note (which
        may name parameters, errors.Text) in a front end's words."""
        return [self.summary()] + [f"  note: {say(n)}" for n in self.model.notes]


def _length_words(metres: float) -> str:
    from ..units import format_length

    return format_length(metres)


def convert_volume(source, params: LithoParams, out_dir, *, stem: str | None = None, printer_profile=None,
                   formats=None, on_price=None) -> VolumeConversion:
    """Make the 3-D model of `source` and write it into `out_dir`: NAME.stl (and 3MF, GLB ...), a
    description and a recipe. Nothing is written unless the mesh is a sound solid as written."""
    from ..export import check_export
    from ..export.files import write_text
    from ..formats import MESH_FORMATS
    from ..printing.print_settings import settings_for
    from ..version import __version__
    from .outputs import dependency_versions, file_sha256, write_meshes
    from .sizing import resolve_printer

    printer = printer_profile or resolve_printer(params)
    formats = list(formats or params.formats)
    flat = [f for f in formats if f not in MESH_FORMATS]  # refused before any work: a model takes seconds to minutes
    if flat:
        raise ParameterError(f"`formats`: a `volume` model is written as a mesh ({', '.join(MESH_FORMATS)}), not as "
                             f"{', '.join(flat)}. Leave {', '.join(flat)} out, or convert without `volume`.", parameter="formats", value=flat)
    model = make_volume(source, params, printer=printer, on_price=on_price)
    folder = Path(out_dir)
    folder.mkdir(parents=True, exist_ok=True)
    stem = stem or Path(source).stem or "model"
    description = describe_volume(model)
    meta = {"title": f"Tactile 3-D model of {model.name}", "description": description, "designer": "TAMP-OS",
            "application": f"TAMP-OS {__version__}", "print_settings": settings_for(printer, params.material)}
    check_export(model.mesh, [folder / f"{stem}.{fmt}" for fmt in formats])
    written = [p for p, _ in write_meshes(model.mesh, folder, stem, formats=formats, meta=meta).values()]
    written.append(write_text(folder / f"{stem}.description.txt", description + "\n"))
    recipe = {
        "kind": "volume", "tamp_os": __version__, "dependencies": dependency_versions(),
        "input": {"name": model.name, "path": model.path, "sha256": model.sha256},
        "params": params.to_dict(), "printer_profile": printer.as_dict(), "files": [p.name for p in written],
        # As every recipe lists them, so `batch` knows a rerun has nothing to do (outputs.recipe_outputs_if_current).
        "outputs": [p.name for p in written], "output_sha256": {p.name: file_sha256(p) for p in written},
        "measured": {
            "size_mm": [round(v, 4) for v in model.size_mm], "triangles": model.mesh.n_triangles,
            "triangles_full_surface": model.triangles_full, "deviation_mm": round(model.deviation_mm, 4),
            "thinnest_wall_mm": round(model.min_wall_mm, 4), "wall_1st_percentile_mm": round(model.wall_p1_mm, 4),
            "level": model.level, "level_from": model.level_from, "parts": model.parts, "genus": model.genus,
            "budget_met": model.budget_met, "meshed_coarser_by": model.coarsened,
            "thin_parts_thickened": model.thin_grown,
            "thin_parts_left": [{"box_mm_xyz": [round(b, 2) for b in r.box_mm], "thinnest_mm": round(r.thinnest_mm, 3), "why": r.why}
                                for r in model.thin_left],
            "voids_filled": model.voids_filled, "specks_dropped": model.specks_dropped, "floating_parts_on_posts": model.floating,
            "working_voxels_zyx": list(model.working_shape), "voxel_m_zyx": list(model.voxel_m) if model.voxel_m else None,
            "sample_m_per_mm": model.sample_m_per_mm, "seconds": round(model.seconds, 2),
            "priced": None if model.price is None else {
                "seconds": round(model.price.seconds, 1), "peak_gb": round(model.price.bytes / 1e9, 3),
                "working_voxels": model.price.voxels, "surface_triangles_at_most": model.price.triangles},
        },
    }
    written.append(write_text(folder / f"{stem}.tamp.json", json.dumps(recipe, indent=2, ensure_ascii=False) + "\n"))
    return VolumeConversion(model, tuple(written))
