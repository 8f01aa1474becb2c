"""make_lithograph(): read -> clean -> relief -> mesh -> tactile furniture, returning data only.

Writing files is outputs.py's job (Lithograph.save only hands over to it); slicing is
slicer.py's, which this module never imports.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..clean.scale import scale_sentence
from ..clean.stage import Cleaned, clean_picture
from ..errors import ParameterError, Text
from ..mesh.adaptive import adaptive_solid
from ..mesh.solid import Mesh, grid_solid
from ..params import LithoParams, field_table
from ..printing.printers import PrinterProfile
from ..read.image import read_array, read_image
from ..read.model import Picture
from ..relief.agreement import agreement
from ..relief.legibility import Legibility, assess
from ..relief.layout import Layout
from ..relief.preprocess import Prepared, prepare
from ..relief.channel_auto import route as channel_route, unused_key_labels
from ..relief.styles import ReliefResult, StyleOptions, make_relief
from ..relief.touch import MOSTLY_NOISE, noise_share
from .report import Report, plate_report
from .sizing import layout_for, resolve_printer
from ..tactile.furniture import Furniture, Placed, add_furniture
from .layout_words import ReliefLayout, find_layout

if TYPE_CHECKING:  # tiles: a bed smaller than the plate only
    from ..tactile.tiles import Tiling

log = logging.getLogger(__name__)

MAX_GRID_ROWS, MAX_GRID_POINTS = 20000, 300e6
# Peak memory per grid point while preprocessing, styling, meshing and checking the mesh as
# written (measured on a 2048 × 1536 grid: 1,070 B with the grid mesher, whose millions of triangles
# go through manifold3d for the cut corner, and 90 B adaptive), and the most a print may take.
MESH_BYTES_PER_POINT = {"grid": 1200, "adaptive": 120}
MAX_MESH_GB = 4.0
# Prints thinner than this are not something a finger can read (and a 65535×2 image is not a picture).
MIN_PRINT_SIDE_MM = 2.0
DEFAULT_DETAIL_MM = 2.0  # about what a fingertip resolves as shape


@dataclass(frozen=True)
class Lithograph:
    """A finished lithograph in memory: nothing here has been written to disk. Frozen: what
    changes it (a figure's panel facts, slicing's result) makes a new one with `dataclasses.replace`."""

    mesh: Mesh  # the closed solid, in mm
    heightmap: np.ndarray  # (rows, cols) heights in mm, row 0 = top of the image = far edge of the print
    params: LithoParams
    printer: PrinterProfile  # the profile with the user's nozzle and layer applied
    layout: Layout
    picture: Picture
    report: Report
    furniture: Furniture | None = None  # what was asked of the tactile furniture (for the 2-D graphics)
    mask: np.ndarray | None = None  # (rows, cols) float over the whole source: 0 kept, 0.5 cropped band, 1 inpainted
    parts: list | None = None  # multicolour: [base, raised] tactile.parts.Part, each closed; mesh is their union
    tiles: Tiling | None = None  # bed_mm smaller than the plate: the tiles to write instead of mesh
    description: str | None = None  # a panel's or overview's own description (figure.py), else made from the report
    recipe_params: LithoParams | None = None  # what the recipe records, when not `params` (a figure's panel)
    channel_regions: np.ndarray | None = None  # a channel print: (picture rows, cols), i = the i-th key entry's region
    objects: np.ndarray | None = None  # the members or shape the relief style found: (rows, cols) labels, 0 = ground (pin displays)

    @property
    def name(self) -> str:
        return Path(self.picture.file.name).stem or "lithograph"

    def metadata(self) -> dict:
        """Title, description, designer and application for the files; see `outputs.metadata`."""
        from .outputs import metadata

        return metadata(self)

    def save(self, target, formats=None, stem: str | None = None) -> list[Path]:
        """Write the mesh in each format, a description and a recipe (see `outputs.save_outputs`),
        and slice it when `gcode` is set; returns the paths written. What slicing found is in the
        Lithograph that `save_sliced` returns (this one does not change)."""
        return self.save_sliced(target, formats, stem)[0]

    def save_sliced(self, target, formats=None, stem: str | None = None) -> tuple[list[Path], Lithograph]:
        """As `save`; also returns this lithograph with the slicing result in `report.print`
        (itself when nothing was sliced)."""
        from .outputs import save_outputs

        return save_outputs(self, target, formats, stem=stem)

    def __repr__(self) -> str:
        r = self.report
        w, d, h = r.print_mm
        return (f"<Lithograph {self.name}: {w:g} × {d:g} × {h:g} mm, grid {r.grid[0]} × {r.grid[1]}, "
                f"{r.triangles:,} triangles, relief style {r.relief_style}>")


def make_lithograph(source, params: LithoParams | None = None, *, printer_profile: PrinterProfile | None = None, **changes) -> Lithograph:
    """Make a lithograph from an image file, an array or a read Picture; nothing is written.

    Parameters
    ----------
    source : str, pathlib.Path, numpy.ndarray or Picture
        An image file (read by its content: TIFF, vendor formats, PNG, JPEG ...), a (rows, cols)
        array of any numeric type (row 0 is the far edge of the print), or a Picture already read.
    params : LithoParams, optional
        Every setting; None gives the defaults (Medium preset, 100 mm wide, 1 mm base, 3 mm relief).
    printer_profile : PrinterProfile, optional
        Replaces the profile that `params.printer` names (a recipe brings its own).
    **changes
        Any LithoParams field by name (`width_mm=50`), applied over `params`.

    Returns
    -------
    Lithograph
        `mesh` (the closed solid, vertices in mm), `heightmap` ((rows, cols) heights in mm),
        `report` (the typed facts), `params`, `printer` and `layout`; `save(folder)` writes it.

    Examples
    --------
    >>> import numpy as np
    >>> ramp = np.tile(np.linspace(0, 1, 80), (60, 1))
    >>> litho = make_lithograph(ramp, width_mm=40, relief_mm=2, preset="low")
    >>> litho.report.print_mm  # width, depth and height in mm: 1 mm base + 2 mm relief
    [40.0, 30.0, 3.0]
    >>> litho.heightmap.shape  # (rows, cols) of the grid, one point per 2 nozzle widths at Low
    (38, 50)
    """
    params = params or LithoParams()
    if changes:
        params = params.replace(**changes)
    timings: dict[str, float] = {}
    clock = _Clock(timings)
    with clock("read"):
        picture = read_source(source, params)
    machine = resolve_printer(params, printer_profile)
    with clock("annotations"):
        cleaned = clean_picture(picture, pixel_size_m=params.pixel_size_m, remove_annotations=not params.keep_annotations)
    layout = layout_for(params, machine, cleaned.values.shape[1], image_h_px=cleaned.values.shape[0])
    _check_grid(layout, params.mesher)
    with clock("preprocess"):
        prepared = _prepare(cleaned, layout, params)
    picture_depth_mm = layout.depth_mm  # before a key grows the plate
    with clock("relief"):
        # several channels, or a stained slide, as textures with a braille key (issue 22), else the usual relief
        route = channel_route(source, picture, params)
        if route is None and not params.channels:
            relief, key, channel_extras = _relief(prepared, layout, params, machine, _content_hints(cleaned)), (), None
            relief = dataclasses.replace(relief, notes=tuple(relief.notes) + unused_key_labels(params.key_labels))
        else:
            from ..relief.channel_stage import channel_path, without_channel_note  # only when used: skimage.color and more

            relief, layout, key, channel_extras = channel_path(_channel_source(source, picture),
                                                lambda: _relief(prepared, layout, params, machine, _content_hints(cleaned)),
                                                layout, params=params, route=route, cleaned=cleaned, title=_document_name(picture))
            if key:
                picture = without_channel_note(picture)
        heights = relief.heights_mm
    with clock("agreement"):  # before the source copy is freed: the check measures the members' shape on it
        agrees = _agreement(prepared, heights, layout, params, cleaned, relief) if not key else ()
    prepared = dataclasses.replace(prepared, fitted=None, fitted_alpha=None)  # the source copy served the relief and its check: free it
    with clock("legibility"):
        legibility = assess(heights, layout.mm_per_px, nozzle_mm=machine.nozzle_mm, layer_mm=machine.layer_mm,
                            objects=relief.objects, style=relief.style)
    max_error = params.max_error_mm if params.max_error_mm is not None else machine.layer_mm / 2
    flattening = _flattening_warning(max_error, params) if params.mesher == "adaptive" else []
    with clock("mesh"):
        mesh = _solid(heights, layout, params.mesher, max_error)
    with clock("scale bar wait"):  # a scale bar's label is read beside the relief and mesh work (clean/stage.py)
        metres = cleaned.pixel_size.metres
    sample_per_mm = metres * prepared.fitted_width_px / layout.width_mm if metres else None
    furniture = furniture_for(params, sample_per_mm)
    with clock("tactile"):
        tactile = _tactile(mesh, layout, params, furniture, machine.bed_mm,
                           _key_in_colour(heights, channel_extras.overlay_mm if channel_extras else None, layout, params, max_error))
    later = flattening + list(tactile.placed.notes if tactile.placed else []) + list(relief.notes) + list(tactile.tiles.notes if tactile.tiles else [])
    legibility = dataclasses.replace(legibility, levels_mm=tuple(round(v, 3) for v in relief.levels_mm),
                                     verdicts=tuple(map(Text, (*relief.checks, *agrees, *legibility.verdicts))))  # what the print shows of the picture first; each a Text, so its advice is said in a front end's words
    report = _report(picture, cleaned, prepared, layout, params, machine, tactile.mesh, tactile.placed, max_error, timings, later,
                     relief, legibility, layout.depth_mm - picture_depth_mm,
                     find_layout(heights, layout.mm_per_px, params.base_mm, relief_mm=params.relief_mm) if not prepared.uniform else None)
    report = dataclasses.replace(report, key=key, check_flags=tuple(agrees))
    return Lithograph(mesh=tactile.mesh, heightmap=heights, params=params, printer=machine, layout=layout, picture=picture,
                      report=report, furniture=furniture, mask=cleaned.source_mask(), parts=tactile.parts, tiles=tactile.tiles,
                      channel_regions=channel_extras.regions if channel_extras else None, objects=relief.objects)


def _agreement(prepared: Prepared, heights: np.ndarray, layout: Layout, params: LithoParams, cleaned, relief: ReliefResult) -> tuple:
    """The print compared with the picture (relief/agreement.py): sentences when what is raised is
    the picture's gaps, or when structure the picture shows is flat on the plate."""
    if prepared.uniform or prepared.image.shape != heights.shape:
        return ()
    signal = cleaned.instrument.signal if cleaned.instrument is not None else None
    return agreement(prepared.image, heights, mm_per_px=layout.mm_per_px, base_mm=params.base_mm, inverted=prepared.invert,
                     signal=signal, polarity=relief.content_kind not in ("lines", "lattice"), style=relief.style,
                     fine=prepared.finer).sentences


@dataclass
class _Tactile:
    mesh: Mesh  # the whole print: relief, plate and furniture fused
    placed: Placed | None  # where the furniture went
    parts: list | None  # two-colour parts (multicolour)
    tiles: Tiling | None  # tiles for a bed smaller than the plate (bed_mm)


def _key_in_colour(heights, key_overlay, layout: Layout, params: LithoParams, max_error: float):
    """(relief mesh without the key's braille and outlines, those as a mesh) for a two-colour print of a
    channel key (issue 22), or None: the second colour carries them, as it carries the caption's braille."""
    if not params.multicolour or key_overlay is None:
        return None
    from ..tactile.parts import key_overlay_meshes

    return key_overlay_meshes(heights, key_overlay, params.base_mm, mesh_of=lambda h: _solid(h, layout, params.mesher, max_error))


def _solid(heights: np.ndarray, layout: Layout, mesher: str, max_error_mm: float) -> Mesh:
    """The closed solid of a heightmap: adaptive (fewest triangles within `max_error_mm`) or every grid point."""
    if mesher == "adaptive":
        return adaptive_solid(heights, layout.width_mm, layout.depth_mm, max_error_mm=max_error_mm)
    return grid_solid(heights, layout.width_mm, layout.depth_mm)


def _tactile(relief_mesh: Mesh, layout: Layout, params: LithoParams, furniture: Furniture,
             printer_bed_mm: tuple[float, float] | None = None, key_meshes=None) -> _Tactile:
    """Furniture (plate, braille, scale bar, frame, cut corner), then two-colour parts or tiles: for
    bed_mm, or else for the printer's own bed (printer_table.py) when the plate is larger than it."""
    mesh, placed = relief_mesh, None
    if furniture.wanted or furniture.corner_cut:
        mesh, placed = add_furniture(relief_mesh, layout.width_mm, layout.depth_mm, base_mm=params.base_mm, furniture=furniture)
    plain, overlay = key_meshes if key_meshes else (relief_mesh, None)
    parts = None
    if params.multicolour:
        from ..tactile.parts import two_colour_parts

        parts = two_colour_parts(plain, layout.width_mm, layout.depth_mm, base_mm=params.base_mm, furniture=furniture, overlay=overlay)[0]
    tiles = None
    bed = params.bed_size_mm if params.bed_mm else (printer_bed_mm if not params.multicolour else None)
    if bed:
        from ..tactile.tiles import tiles_for

        (ox, oy), legs = (placed.relief_origin_mm, placed.corner_cut_mm) if placed else ((0.0, 0.0), 0.0)
        picture_box = (ox, oy, ox + layout.width_mm, oy + layout.depth_mm)
        tiles = tiles_for(mesh, bed, params.base_mm, spec=furniture.spec, picture_box=picture_box, corner_legs_mm=legs)
    return _Tactile(mesh, placed, parts, tiles)


# Who hears each stage begin (a front end's progress bar and its Cancel button, napari/widget.py):
# per thread of work, so two conversions side by side never hear each other's stages.
STAGES = ("read", "annotations", "preprocess", "relief", "agreement", "legibility", "mesh", "scale bar wait", "tactile")
_STAGE_LISTENER: ContextVar[Callable[[str], None] | None] = ContextVar("stage_listener", default=None)


@contextmanager
def stages_heard_by(listener: Callable[[str], None]):
    """Within this block, `listener(stage)` is called as each stage of a lithograph begins (STAGES,
    then "save" before its files are written). An exception it raises stops the work there, before
    the stage: that is how a front end cancels, and no file is half written."""
    token = _STAGE_LISTENER.set(listener)
    try:
        yield
    finally:
        _STAGE_LISTENER.reset(token)


def stage_begins(stage: str) -> None:
    """Tell the listener, if any, that `stage` begins (see stages_heard_by)."""
    listener = _STAGE_LISTENER.get()
    if listener is not None:
        listener(stage)


class _Clock:
    """`with clock("stage"):` adds the stage's wall time in seconds to `timings` (and says the
    stage begins, to whoever listens: stages_heard_by)."""

    def __init__(self, timings: dict[str, float]):
        self.timings, self.stage, self.start = timings, "", 0.0

    def __call__(self, stage: str) -> "_Clock":
        stage_begins(stage)
        self.stage = stage
        return self

    def __enter__(self):
        self.start = time.perf_counter()

    def __exit__(self, *exc):
        self.timings[self.stage] = time.perf_counter() - self.start


@dataclass(frozen=True)
class ChannelPlan:
    """What `convert` will make of a picture's channels, for `info` to say before it is made."""

    why: str  # the rule that sent it down the channel path ("the file has 4 channels")
    key: tuple  # KeyEntry per printed channel: its label ("nuclei (DAPI)") and encoding
    notes: tuple  # the choice's own notes (channels left out, roles from the file's name)


def plan_channels(source, params: LithoParams | None = None) -> ChannelPlan | None:
    """The channel print `make_lithograph(source, params)` would make (its key), or None when it
    prints the brightness: the same reading, cleaning, layout and choice, without the relief's
    heights, mesh or furniture."""
    from ..relief.channel_stage import run as channel_stage

    params = params or LithoParams()
    picture = read_source(source, params)
    route = channel_route(source, picture, params)
    if route is None and not params.channels:
        return None
    cleaned = clean_picture(picture, pixel_size_m=params.pixel_size_m, remove_annotations=not params.keep_annotations)
    layout = layout_for(params, resolve_printer(params, None), cleaned.values.shape[1], image_h_px=cleaned.values.shape[0])
    stage = channel_stage(_channel_source(source, picture), layout, params, route=route, cleaned=cleaned, title=_document_name(picture))
    if stage is None:
        return None
    why = route.why if route is not None else "`channels` assigns them"
    return ChannelPlan(why, stage.key, tuple(stage.relief.notes))


def _document_name(picture: Picture) -> str:
    """The name the microscope's software gave the picture (a CZI's document name, which often
    says what each channel shows: "mCherryEB3_GFPMito"), or ""."""
    vendor = picture.file.metadata.get("vendor") if picture.file is not None else None
    return str(vendor.get("czi_document_name") or "") if isinstance(vendor, dict) else ""


def _channel_source(source, picture: Picture):
    """What the channel path reads the channels from: the file or array given, or a Picture's
    colour pixels (a panel of a colour figure), else its luminance (one plain channel)."""
    if not isinstance(source, Picture):
        return source
    return picture.colour if picture.colour is not None else picture.values


def read_source(source, params: LithoParams, keep_colour: bool = False) -> Picture:
    """`keep_colour`: keep an RGB file's colour pixels in Picture.colour (read.read_image)."""
    if isinstance(source, Picture):
        return source
    if isinstance(source, (str, Path)):
        return read_image(source, **params.read_options(target_px=_pyramid_target_px(params), keep_colour=keep_colour))
    return read_array(source, channel=params.channel)


make_lithograph.__doc__ += "\n    Parameters (in `params` or as keyword changes):\n" + field_table().replace("\n    ", "\n        ")


def _pyramid_target_px(params: LithoParams) -> int:
    """Of a pyramid, the level to read: at least 4 source pixels per grid point, and at least 2048 px."""
    return max(2048, 4 * (params.resolution_px or 0))


def _check_grid(layout: Layout, mesher: str) -> None:
    """Refuse, before any work, a grid too large to mesh in bounded memory or a print too thin to read."""
    if min(layout.width_mm, layout.depth_mm) < MIN_PRINT_SIDE_MM:
        raise ParameterError(
            f"`depth_mm`: the print would be {layout.width_mm:.3g} × {layout.depth_mm:.3g} mm, thinner than "
            f"{MIN_PRINT_SIDE_MM:g} mm, which nothing can read by touch (the image is very long and thin). "
            f"Give both `width_mm` and `depth_mm` (at least {MIN_PRINT_SIDE_MM:g} mm) with fit pad, or crop the image."
        )
    points = layout.cols * layout.rows
    need_gb = points * MESH_BYTES_PER_POINT[mesher] / 1e9
    if layout.rows > MAX_GRID_ROWS or points > MAX_GRID_POINTS or need_gb > MAX_MESH_GB:
        raise ParameterError(
            f"`resolution_px`: a {layout.cols}×{layout.rows} grid would need about {need_gb:.1f} GB of memory with the "
            f"{mesher} mesher (at most {MAX_MESH_GB:g} GB); lower `resolution_px` or the preset"
            + (", or use the adaptive mesher." if mesher == "grid" else ".")
        )


def _flattening_warning(max_error_mm: float, params: LithoParams) -> list[str]:
    """A sentence when the adaptive mesh may leave out height steps a finger would feel (~0.5 mm)."""
    if max_error_mm <= min(0.25, params.relief_mm / 4):
        return []
    return [Text(f"`max_error_mm` {max_error_mm:g} mm lets the mesh leave out height steps of up to that size (a finger feels "
            f"about 0.5 mm, and the relief is {params.relief_mm:g} mm): shapes may come out flattened. "
            f"Half a layer height (the default) keeps every step.")]


def _prepare(cleaned: Cleaned, layout: Layout, params: LithoParams) -> Prepared:
    return prepare(
        cleaned.values, cleaned.alpha, rows=layout.rows, cols=layout.cols, target_aspect=layout.target_aspect, fit=layout.fit,
        low_pct=params.stretch_low_pct, high_pct=params.stretch_high_pct, sigma_px=layout.blur_px,
        invert=params.invert, flip_x=params.flip_x,
    )


def _content_hints(cleaned: Cleaned):
    """The file's detector and signal, for the content relief style's choice (issue 26)."""
    from ..relief.content import ContentHints

    instrument = cleaned.instrument
    return ContentHints(instrument.detector, instrument.signal) if instrument else None


def _relief(prepared: Prepared, layout: Layout, params: LithoParams, machine: PrinterProfile, hints=None) -> ReliefResult:
    """Heights in mm from the prepared image, in the chosen relief style."""
    # Unset, the detail scale is a fingertip's (2 mm), or the grid pitch where the grid is coarser.
    detail_mm = params.detail_mm if params.detail_mm is not None else max(DEFAULT_DETAIL_MM, layout.mm_per_px)
    options = StyleOptions(detail_mm=detail_mm, texture_mm=params.texture_mm, level_count=params.level_count,
                           nozzle_mm=machine.nozzle_mm)
    return make_relief(prepared.image, style=params.relief_style, mm_per_px=layout.mm_per_px, base_mm=params.base_mm,
                       relief_mm=params.relief_mm, layer_mm=machine.layer_mm if params.quantize else None,
                       options=options, uniform=prepared.uniform, hints=hints, fine=prepared.finer)


def furniture_for(params: LithoParams, sample_per_mm: float | None) -> Furniture:
    return Furniture(
        caption=params.caption,
        braille_table=params.braille_table,
        scale_bar_m=_scale_bar_m(params, sample_per_mm),
        auto_scale_bar=params.scale_bar == "auto",
        corner_cut=params.orientation_corner == "cut",
        sample_m_per_print_mm=sample_per_mm,
        frame_mm=params.frame_mm,
        spec=params.braille_spec(),
    )


def _scale_bar_m(params: LithoParams, sample_per_mm: float | None) -> float | None:
    """The sample length the scale bar stands for, from scale_bar = auto | off | a length."""
    setting = params.scale_bar
    if setting in ("off", "auto"):  # auto: chosen by the furniture layout, to fit the plate
        return None
    if not sample_per_mm:
        raise ParameterError(
            f"`scale_bar`: a scale bar of {setting} needs the image's pixel size, and none is known; "
            f"give `pixel_size` (for example 4.2nm) or set `scale_bar` to off."
        )
    return params.scale_bar_m


def _warnings(picture: Picture, cleaned: Cleaned, prepared: Prepared, layout: Layout, params: LithoParams,
              later: list[str]) -> list[str]:
    """Every warning of a print, in one list, each logged once (`later`: those of the mesh and furniture stages)."""
    warnings = list(layout.warnings) + list(picture.file.notes) + list(cleaned.pixel_size.warnings)
    if prepared.uniform:
        warnings.append(f"{picture.file.name}: the image is uniform (every usable pixel has the same value); the print is a flat plate.")
    elif cleaned.values.ndim == 2:
        noise = noise_share(cleaned.values, prepared.stretch_source_range)
        if noise > MOSTLY_NOISE:  # the shapes said and printed would be the noise's grain (the DM3 fixture: 91 %)
            warnings.append(f"{picture.file.name}: the picture is mostly noise (noise is {noise:.0%} of its contrast): the "
                            f"shapes on the print are its grain, not structure in the sample; check that this is the image "
                            f"meant, or average or denoise it first.")
    if params.base_mm < 0.8:
        warnings.append(Text(f"`base_mm` {params.base_mm} is below 0.8 mm; thin bases warp and break. 1.0–1.5 mm is typical."))
    warnings += later
    for w in warnings:
        log.warning(w)
    return warnings


def _report(picture, cleaned, prepared, layout, params, machine, mesh, placed, max_error, timings, later,
            relief: ReliefResult, legibility: Legibility, key_depth_mm: float, relief_layout: ReliefLayout | None) -> Report:
    scale = cleaned.pixel_size
    source_px_per_print_mm = prepared.fitted_width_px / layout.width_mm
    return plate_report(
        picture=picture, mesh=mesh, plan=layout, machine=machine, params=params, placed=placed,
        blur_px=round(layout.blur_px, 3),
        max_error_mm=max_error if params.mesher == "adaptive" else 0.0,
        uniform=prepared.uniform,
        pixel_size_m=scale.metres,
        pixel_size_source=scale.provenance,
        scale=scale_sentence(scale.metres, source_px_per_print_mm) if scale.metres else "no physical scale is known",
        crop=cleaned.band,
        annotations=tuple(cleaned.annotations_with_text),
        warnings=tuple(_warnings(picture, cleaned, prepared, layout, params, later)),
        timings_s={k: round(v, 4) for k, v in timings.items()},
        relief_style=relief.style,
        relief_reason=relief.reason,
        content_kind=relief.content_kind,
        lattice_pitch_mm=round(relief.lattice_pitch_mm, 3) if relief.lattice_pitch_mm else None,
        legibility=legibility,
        instrument=cleaned.instrument,
        layout=relief_layout,
        key_depth_mm=round(key_depth_mm, 3),
    )


