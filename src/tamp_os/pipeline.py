"""make_lithograph(): read -> preprocess -> heightmap -> mesh, and Lithograph.save()."""

from __future__ import annotations

import functools
import json
import logging
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__
from .mesh.adaptive import adaptive_solid
from .clean.stage import clean_source
from .errors import InputError, ParameterError
from .export import check_export, save_mesh
from .files import write_png, write_text
from .relief.heightmap import heights_mm
from .mesh.solid import Mesh, grid_solid
from .clean.scale import scale_sentence
from .params import LithoParams
from .relief.preprocess import prepare
from .printers import get_printer, height_levels
from .read import Picture, read_array, read_image
from .relief.layout import Layout, plan_layout
from .slicer import material, slice_mesh
from .tactile.furniture import Furniture, add_furniture
from .units import parse_length_m

log = logging.getLogger(__name__)

RECIPE_SUFFIX = ".tamp.json"
PARALLEL_WRITE_TRIANGLES = 100_000


@dataclass
class Lithograph:
    mesh: Mesh
    heightmap: np.ndarray  # heights in mm, row 0 = top of the image = far edge of the print
    params: LithoParams
    layout: Layout
    picture: Picture
    report: dict = field(default_factory=dict)
    mask: np.ndarray | None = None  # annotations removed from the (cropped) source image

    @property
    def name(self) -> str:
        return Path(self.picture.source.name).stem or "lithograph"

    def metadata(self) -> dict:
        return {
            "title": f"Tactile lithograph of {self.picture.source.name}",
            "description": describe(self),
            "designer": "TAMP-OS",
            "application": f"TAMP-OS {__version__}",
        }

    def save(self, target, formats=None, stem: str | None = None) -> list[Path]:
        """Write the mesh in each format, a description and a recipe sidecar.

        `target` is a folder (files are named `stem`, by default after the input) or a file name
        whose extension picks the single format. Returns the paths written, recipe last.
        """
        target = Path(target)
        if target.suffix and not target.is_dir():
            folder, stem, formats = target.parent, target.stem, [target.suffix.lstrip(".").lower()]
        else:
            folder, stem = target, stem or self.name
            formats = list(formats or self.params.formats)
        if not folder.exists():
            try:
                folder.mkdir(parents=True)
            except OSError as exc:
                from .errors import ExportError

                raise ExportError(f"{folder}: cannot create the output folder ({exc.strerror}); choose another with -o.") from None
        meta = self.metadata()
        # Every format is checked before any is written: a failure leaves no file.
        check_export(self.mesh, [folder / f"{stem}.{fmt}" for fmt in formats + (["stl"] if self.params.gcode else [])])

        def write(fmt):
            start = time.perf_counter()
            path = save_mesh(self.mesh, folder / f"{stem}.{fmt}", meta, checked=True)
            self.report["timings_s"][f"write_{fmt}"] = round(time.perf_counter() - start, 4)
            return path

        # Large meshes: the writers spend their time in NumPy and lib3mf's C code, which release
        # the GIL, so writing the formats side by side uses both cores. Small ones: threads cost more.
        if self.mesh.n_triangles > PARALLEL_WRITE_TRIANGLES and len(formats) > 1:
            with ThreadPoolExecutor(max_workers=min(len(formats), os.cpu_count() or 1)) as pool:
                written = list(pool.map(write, formats))
        else:
            written = [write(fmt) for fmt in formats]
        if self.params.save_masks and self.mask is not None:
            written.append(write_png(folder / f"{stem}.annotations.png", (self.mask * 255).astype(np.uint8)))
        if self.params.gcode:
            sliced_from = next((p for p in written if p.suffix == ".stl"), None)
            if sliced_from is None:
                sliced_from = save_mesh(self.mesh, folder / f"{stem}.stl", meta, checked=True)
                written.append(sliced_from)
            result = slice_mesh(
                sliced_from, get_printer(self.params.printer), material(self.params.material, self.params.filament_price_per_kg),
                timeout_s=self.params.slice_timeout_s, layer_mm=self.report["layer_mm"], nozzle_mm=self.report["nozzle_mm"],
            )
            written.append(Path(result.gcode))
            self.report["print"] = {**result.as_dict(), "gcode": Path(result.gcode).name, "summary": result.sentence()}
        written.append(write_text(folder / f"{stem}.description.txt", meta["description"] + "\n"))
        recipe = folder / f"{stem}{RECIPE_SUFFIX}"
        files = [p.name for p in written]
        text = json.dumps(recipe_dict(self, files), indent=2, ensure_ascii=False) + "\n"
        write_text(recipe, text)
        self.report["files"] = files + [recipe.name]
        return written + [recipe]


@functools.lru_cache(maxsize=1)
def dependency_versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for name in ("numpy", "scipy", "scikit-image", "tifffile", "pillow", "trimesh", "lib3mf"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


def recipe_dict(litho: Lithograph, files: list[str]) -> dict:
    src = litho.picture.source
    return {
        "tamp_os_version": __version__,
        "input": {"name": src.name, "path": src.path, "sha256": src.sha256},
        "params": litho.params.to_dict(),
        "outputs": files,
        "print": litho.report.get("print"),
        "versions": dict(dependency_versions()),
    }


def load_recipe(path) -> tuple[Path, LithoParams, dict]:
    """(input path, params, recipe) from a recipe sidecar; the input must still hash the same."""
    import hashlib

    path = Path(path)
    try:
        recipe = json.loads(path.read_text(encoding="utf-8"))
        params = LithoParams.from_dict(recipe["params"])
        info = recipe["input"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{path}: not a readable TAMP-OS recipe ({exc}).") from None
    candidates = [Path(info["path"])] if info.get("path") else []
    candidates.append(path.parent / info["name"])
    for image in candidates:
        if image.is_file():
            if hashlib.sha256(image.read_bytes()).hexdigest() != info["sha256"]:
                raise InputError(
                    f"{path}: the input {image} has changed since the recipe was written (SHA-256 differs); "
                    f"the same output cannot be rebuilt from it."
                )
            return image, params, recipe
    raise InputError(f"{path}: its input {info['name']} was not found at {', '.join(map(str, candidates))}.")


def make_lithograph(source, params: LithoParams | None = None, **changes) -> Lithograph:
    """Make a lithograph from an image file or array.

    >>> litho = make_lithograph(np.eye(64), width_mm=50, relief_mm=2)   # doctest: +SKIP
    >>> litho.save("out/")                                              # doctest: +SKIP
    """
    params = params or LithoParams()
    if changes:
        params = params.replace(**changes)
    timings = {}
    start = time.perf_counter()
    if isinstance(source, Picture):
        picture = source
    elif isinstance(source, (str, Path)):
        picture = read_image(
            source, page=params.page, channel=params.channel, max_megapixels=params.max_megapixels, z_slice=params.z_slice
        )
    else:
        picture = read_array(source, channel=params.channel)
    timings["read"] = time.perf_counter() - start

    printer = get_printer(params.printer)
    nozzle = params.nozzle_mm or printer.nozzle_mm
    layer = params.layer_mm or printer.layer_mm
    src = picture.source
    start = time.perf_counter()
    cleaned = clean_source(picture, pixel_size=params.pixel_size, remove_annotations=not params.keep_annotations)
    values, alpha, scale = cleaned.values, cleaned.alpha, cleaned.scale
    timings["annotations"] = time.perf_counter() - start
    layout = plan_layout(
        values.shape[1],
        values.shape[0],
        width_mm=params.width_mm,
        height_mm=params.height_mm,
        default_width_mm=printer.width_mm,
        fit=params.fit,
        preset=params.preset,
        nozzle_mm=nozzle,
        resolution_px=params.resolution_px,
        blur_px=params.blur_px,
        blur_mm=params.blur_mm,
    )
    if layout.rows > 20000 or layout.cols * layout.rows > 300e6:
        raise ParameterError(
            f"resolution_px: {layout.cols}×{layout.rows} grid points is too many to mesh; lower --resolution-px or the preset."
        )
    start = time.perf_counter()
    image, info = prepare(
        values,
        alpha,
        rows=layout.rows,
        cols=layout.cols,
        target_aspect=layout.target_aspect,
        fit=layout.fit,
        low_pct=params.stretch_low_pct,
        high_pct=params.stretch_high_pct,
        sigma_px=layout.sigma_px,
        invert=params.invert,
        flip_x=params.flip_x,
    )
    heights = heights_mm(image, base_mm=params.base_mm, relief_mm=params.relief_mm, layer_mm=layer if params.quantize else None)
    timings["preprocess"] = time.perf_counter() - start

    start = time.perf_counter()
    max_error = params.max_error_mm if params.max_error_mm is not None else layer / 2
    if params.mesher == "adaptive":
        mesh = adaptive_solid(heights, layout.width_mm, layout.depth_mm, max_error)
    else:
        mesh = grid_solid(heights, layout.width_mm, layout.depth_mm)
    timings["mesh"] = time.perf_counter() - start

    start = time.perf_counter()
    sample_per_mm = scale.pixel_size_m * info["fitted_width_px"] / layout.width_mm if scale.pixel_size_m else None
    furniture = Furniture(
        caption=params.caption,
        braille_table=params.braille_table,
        scale_bar_m=_scale_bar_m(params.scale_bar, sample_per_mm),
        auto_scale_bar=params.scale_bar == "auto",
        corner_cut=params.orientation_corner == "cut",
        sample_m_per_print_mm=sample_per_mm,
        frame_mm=params.frame_mm,
        spec=params.braille_spec(),
    )
    placed = None
    if furniture.wanted or furniture.corner_cut:
        mesh, placed = add_furniture(mesh, layout.width_mm, layout.depth_mm, params.base_mm, furniture)
    timings["tactile"] = time.perf_counter() - start

    warnings = list(layout.warnings) + list(src.notes) + scale.warnings + (placed.notes if placed else [])
    if info["uniform"]:
        warnings.append(f"{src.name}: the image is uniform (every usable pixel has the same value); the print is a flat plate.")
    if params.base_mm < 0.8:
        warnings.append(f"base_mm {params.base_mm} is below 0.8 mm; thin bases warp and break. 1.0–1.5 mm is typical.")
    for w in warnings:
        log.warning(w)
    report = {
        "input": src.name,
        "print_mm": [round(float(v), 3) for v in mesh.bounds_mm[1]],
        "relief_mm": [round(layout.width_mm, 3), round(layout.depth_mm, 3)],
        "grid": [layout.cols, layout.rows],
        "mm_per_px": round(layout.mm_per_px, 4),
        "blur_px": round(layout.sigma_px, 3),
        "printer": printer.name,
        "nozzle_mm": nozzle,
        "layer_mm": layer,
        "height_levels": height_levels(params.relief_mm, layer),
        "mesher": params.mesher,
        "max_error_mm": max_error if params.mesher == "adaptive" else 0.0,
        "triangles": mesh.n_triangles,
        "vertices": len(mesh.vertices),
        "uniform": info["uniform"],
        "pixel_size_m": scale.pixel_size_m,
        "pixel_size_source": scale.source,
        "scale": scale_sentence(scale.pixel_size_m, info["fitted_width_px"] / layout.width_mm) if scale.pixel_size_m else "no physical scale is known",
        "tactile": _tactile_report(placed),
        "crop": cleaned.crop,
        "annotations": [a.describe() for a in cleaned.annotations],
        "warnings": warnings,
        "timings_s": {k: round(v, 4) for k, v in timings.items()},
        "files": [],
    }
    return Lithograph(mesh=mesh, heightmap=heights, params=params, layout=layout, picture=picture, report=report, mask=cleaned.mask)


def _scale_bar_m(setting: str, sample_per_mm: float | None) -> float | None:
    """The sample length the scale bar stands for, from --scale-bar auto|off|LENGTH."""
    if setting == "off":
        return None
    if setting == "auto":  # chosen by the furniture layout, to fit the plate
        return None
    if not sample_per_mm:
        raise ParameterError(
            f"scale_bar: --scale-bar {setting} needs the image's pixel size, and none is known; "
            f"give it with --pixel-size (for example --pixel-size 4.2nm) or use --scale-bar off."
        )
    return parse_length_m(setting, "scale_bar")


def _tactile_report(placed) -> dict | None:
    if placed is None:
        return None
    return {
        "plate_mm": [round(v, 3) for v in placed.plate_mm],
        "relief_origin_mm": [round(v, 3) for v in placed.relief_origin_mm],
        "caption_braille": placed.caption_braille,
        "caption_box_mm": placed.caption_box,
        "scale_bar_box_mm": placed.scale_bar_box,
        "scale_bar_label": placed.scale_label,
        "scale_bar_label_braille": placed.scale_label_braille,
        "scale_label_box_mm": placed.scale_label_box,
        "frame_box_mm": placed.frame_box,
        "braille_dots": placed.dots,
        "scale_label_beside": placed.scale_label_beside,
        "orientation": "cut corner at the top right" if placed.corner_cut_mm else None,
    }


def describe(litho: Lithograph) -> str:
    """A plain-language description of the object for people who cannot see it."""
    r, p = litho.report, litho.params
    w, d, h = r["print_mm"]
    rw, rd = r["relief_mm"]
    raised = "dark" if p.invert else "bright"
    parts = [
        f"A tactile relief of the image {litho.picture.source.name}.",
        f"The object is {w:g} mm wide, {d:g} mm deep and up to {h:g} mm high, on a {p.base_mm:g} mm base.",
        f"The picture itself is {rw:g} by {rd:g} mm. The top edge of the image is the far edge of the print.",
        f"The {raised} parts of the image are raised, up to {p.relief_mm:g} mm above the base.",
        f"Scale: {r['scale']}.",
    ]
    t = r.get("tactile")
    if t:
        if t["orientation"]:
            parts.append("The top right corner of the plate is cut off at 45 degrees: hold the print with that corner at the top right.")
        if t["frame_box_mm"]:
            parts.append(f"A raised frame {p.frame_mm:g} mm wide surrounds the picture.")
        if t["scale_bar_box_mm"]:
            parts.append(
                f"Below the picture, at the left, a raised scale bar with end ticks stands for {t['scale_bar_label']} "
                f"in the sample; its value is in braille {'to its right' if t['scale_label_beside'] else 'below it'}."
            )
        if t["caption_braille"]:
            parts.append(f"Along the bottom margin, a braille caption reads: {p.caption}.")
    return " ".join(parts)
