"""Writing a lithograph: output names, the mesh formats, the description, the mask and the recipe
sidecar (NAME.tamp.json) that rebuilds the print exactly; reading a recipe back and matching it
against an input (batch resume). Files are opened only through files.write_atomic."""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np


from ..errors import ExportError, InputError, ParameterError
from ..export import check_formats, check_written_solid, format_of, save_mesh
from ..export.files import to_uint8, write_png, write_text, written_sha256
from ..formats import BY_NAME, DOCUMENT_FORMATS, GRAPHIC_FORMATS, PIN_FORMATS, by_suffix
from ..params import LithoParams
from ..printing.printers import PrinterProfile
from .report import Printing, describe
from ..version import __version__

if TYPE_CHECKING:  # the 2-D graphics code is imported only when a PDF or SVG is written
    from ..export.graphic2d import Graphic2D
    from ..printing.slicer import SliceResult

RECIPE_SUFFIX = ".tamp.json"
# Side by side from this many triangles (measured: FePt's 9,296 9.7 -> 8.2 ms, SiO2 10 kx's 58,030
# 65 -> 58 ms; a mesh of a few thousand triangles is written in a millisecond or two either way).
PARALLEL_WRITE_TRIANGLES = 5_000


def metadata(litho) -> dict:
    """Title, description, designer and application, for formats that carry them (3MF, GLB), and the
    print settings the 3MF carries for the slicer (export/print_settings.py)."""
    from ..printing.print_settings import resin_sentence, settings_for
    from ..printing.slicer import material

    if litho.printer.is_resin:  # no FDM slicer settings in the 3MF: the description says how to print it
        settings, how = None, resin_sentence(litho.printer, litho.params.relief_mm)
    else:
        settings = settings_for(litho.printer, material(litho.params.material).filament_type or litho.params.material)
        how = settings.sentence(in_3mf="3mf" in litho.params.formats)
    return {
        "title": f"Tactile lithograph of {litho.picture.file.name}",
        "description": " ".join([litho.description or describe(litho.report, litho.params, litho.picture.file.name),
                                 *multipart_sentences(litho), how]),
        "designer": "TAMP-OS",
        "application": f"TAMP-OS {__version__}",
        "print_settings": settings,
    }


def multipart_sentences(litho) -> list[str]:
    """How the parts or tiles go together, for the description (tactile/parts.py, tiles.py)."""
    out = []
    if getattr(litho, "parts", None):
        from ..tactile.parts import describe_parts

        out.append(describe_parts(litho.parts))
    if getattr(litho, "tiles", None):
        from ..tactile.tiles import describe_tiles

        out.append(describe_tiles(litho.tiles))
    return out


def save(litho, target, formats=None, *, stem: str | None = None) -> list[Path]:
    """Write the mesh in each format, the mask if asked, a description and a recipe.

    `target` is a folder (files are named `stem`, by default after the input) or a file name
    whose extension picks the single format. Returns the paths written, recipe last.
    """
    folder, stem, formats = _target(litho, Path(target), formats, stem)
    meta = metadata(litho)
    graphics = [f for f in formats if f in GRAPHIC_FORMATS]
    pins = [f for f in formats if f in PIN_FORMATS]
    documents = [f for f in formats if f in DOCUMENT_FORMATS]  # eBraille and the touch tour (issue 35)
    meshes = [f for f in formats if f not in GRAPHIC_FORMATS and f not in PIN_FORMATS and f not in DOCUMENT_FORMATS]
    # The mesh as written, every format's own limits and the graphics' page are checked before any file is written.
    graphic = tactile_graphic(litho) if graphics or documents else None
    if graphics:
        from ..export.graphic2d import page_placement

        page_placement(graphic.plate_mm, litho.params.page_size)
    pages = None
    if pins:  # pin-display pages (export/pins.py): a picture too fine for the pins fails here, before any file
        from ..export.pin_files import pin_sets

        pages = pin_sets(litho, pins)
    built = {}
    if documents:  # eBraille and the tour made here: a text braille cannot write fails before any file
        from ..export.tour import build_documents

        built = build_documents(litho, graphic, documents, stem=stem, description=meta["description"])
    if litho.tiles or litho.parts:  # several solids (export/multipart.py)
        written = _write_multipart(litho, folder, stem, meshes, meta)
    else:
        written = _write_checked(litho.mesh, folder, stem, meshes, meta)
    if graphics:
        from ..export.tactile2d import save_graphic  # cairo's writer, imported only for PDF/SVG

        written += [save_graphic(graphic, folder / f"{stem}.{fmt}", litho.params.page_size, metadata=meta) for fmt in graphics]
    if pages:
        from ..export.pin_files import save_pins

        for fmt, pin_set in pages.items():
            written += save_pins(pin_set, fmt, folder, stem=stem, title=meta["title"])
    if built:
        from ..export.tour import write_documents

        written += write_documents(folder, built)
    if litho.params.save_masks and litho.mask is not None:
        written.append(write_png(folder / f"{stem}.annotations.png", to_uint8(litho.mask, 0.0, 1.0)))
    written.append(write_text(folder / f"{stem}.description.txt", meta["description"] + "\n"))
    recipe = write_recipe(litho, folder / f"{stem}{RECIPE_SUFFIX}", [p.name for p in written])
    return written + [recipe]


def _write_checked(mesh, folder: Path, stem: str, formats: list[str], meta: dict) -> list[Path]:
    """The mesh in each format, refused as check_export refuses it (the same errors, in the same
    order), its solid check running beside the writing: no file takes its name before it passes."""
    paths = [folder / f"{stem}.{fmt}" for fmt in formats]
    for path in paths:
        format_of(path)  # a name no format writes fails first
    try:
        check_formats(mesh, paths)
    except ExportError:
        check_written_solid(mesh, paths)  # a mesh failing both is refused for its solid first
        raise
    written = write_meshes(mesh, folder, stem, formats=formats, meta=meta, check=lambda: check_written_solid(mesh, paths))
    return [path for path, _ in written.values()]


def _write_multipart(litho, folder: Path, stem: str, formats: list[str], meta: dict) -> list[Path]:
    from ..export.multipart import write_parts, write_tiles

    if litho.tiles:
        return write_tiles(litho.tiles, folder, stem, formats=formats, meta=meta)
    return write_parts(litho.parts, litho.mesh, folder, stem=stem, formats=formats, meta=meta)


LONGEST_SUFFIX_BYTES = 48  # '.description.txt', '.annotations.png', part and tile names, + a temporary name's 15


def _target(litho, target: Path, formats, stem) -> tuple[Path, str, list[str]]:
    from ..export.files import check_path_length

    check_path_length(target)  # before any look at the file system: a too-long name fails there
    document = next((f for f in DOCUMENT_FORMATS if target.name.lower().endswith(BY_NAME[f].suffix)), None)
    if document and not target.is_dir():  # NAME.ebrl, NAME.tour.html (a suffix of two parts)
        folder, stem, formats = target.parent, target.name[: -len(BY_NAME[document].suffix)], [document]
    elif target.suffix and not target.is_dir():
        if by_suffix(target.suffix) is None:  # else a two-colour or tiled print would fail deep in the writers
            raise ParameterError(
                f"{target}: no format is written as '{target.suffix}'; name a file ending in one of "
                f"{', '.join(sorted({x for f in BY_NAME.values() for x in f.suffixes}))}, or give a folder (one that exists, or a name without a dot)."
            )
        folder, stem, formats = target.parent, target.stem, [target.suffix.lstrip(".").lower()]
    else:
        folder, stem = target, stem or litho.name
        formats = list(formats or litho.params.formats)
    check_path_length(folder / stem, LONGEST_SUFFIX_BYTES)  # every file of the set fits, or none is written
    if not folder.exists():
        try:
            folder.mkdir(parents=True)
        except OSError as exc:
            raise ExportError(f"{folder}: cannot create the output folder ({exc.strerror}); choose another.") from None
    return folder, stem, formats


def distinct_stems(paths: list[Path]) -> list[str]:
    """Output names for inputs written into one folder in one run: each input's stem, or, where
    two would share one (a.png, a.tif), stem_extension (a_png, a_tif), then a number if needed."""
    stems = [Path(p).stem or "lithograph" for p in paths]
    counts = {s: stems.count(s) for s in stems}
    stems = [f"{s}_{Path(p).suffix.lstrip('.').lower()}" if counts[s] > 1 and Path(p).suffix else s for s, p in zip(stems, paths)]
    seen: dict[str, int] = {}
    out = []
    for s in stems:
        seen[s] = seen.get(s, 0) + 1
        out.append(s if seen[s] == 1 else f"{s}_{seen[s]}")
    return out


def tactile_graphic(litho) -> Graphic2D:
    """The lithograph as a 2-D tactile graphic: its relief as at most three regions that differ by
    touch (the levels style's plateaus, the objects found, or thresholds of the heights), with the
    same caption, scale bar and cut corner as the 3-D plate."""
    from ..export.graphic2d import layout_graphic, regions_from_image  # only for PDF/SVG

    relief = (litho.heightmap - litho.params.base_mm) / litho.params.relief_mm
    legibility = litho.report.legibility
    objects = litho.report.relief_style == "objects" and legibility is not None and legibility.object_count
    if litho.report.uniform:
        regions = np.zeros(relief.shape, np.int32)
    elif objects:
        regions = (relief > 0.5).astype(np.int32)  # the domes: one texture over a plain background
    else:
        levels = len((legibility.levels_mm if legibility else None) or []) - 1
        regions = regions_from_image(np.clip(relief, 0, 1), levels=min(3, levels) if levels >= 1 else 3)
    furniture = litho.furniture
    bar = litho.report.tactile.scale_bar_box_mm if litho.report.tactile else None
    if furniture is not None and bar and furniture.scale_bar_m is None and furniture.sample_m_per_print_mm:
        furniture = dataclasses.replace(furniture, scale_bar_m=(bar[2] - bar[0]) * furniture.sample_m_per_print_mm)
    channel = getattr(litho, "channel_regions", None)
    if channel is not None and litho.report.key:  # issue 22: each channel its own paper texture, and the key
        from ..relief.channel_stage import paper_textures

        textures = paper_textures(litho.report.key)
        key = [(textures[i + 1], e.braille) for i, e in enumerate(litho.report.key)]
        return layout_graphic(channel, litho.layout.width_mm / channel.shape[1], furniture, textures=textures, key=key)
    return layout_graphic(regions, litho.layout.width_mm / regions.shape[1], furniture)


def write_meshes(mesh, folder: Path, stem: str, *, formats: list[str], meta: dict,
                 check: Callable[[], None] | None = None) -> dict[str, tuple[Path, float]]:
    """Write `mesh` as folder/stem.FMT for each format: {format: (path, seconds)}. `check`, when
    given, raises if the mesh must not be written: it runs first or, when the formats are written
    side by side, beside them, and no file takes its name unless it passes."""
    gate = _Gate()

    def write(fmt):
        start = time.perf_counter()
        path = save_mesh(mesh, folder / f"{stem}.{fmt}", meta, checked=True, before_replace=gate.wait if check else None)
        return fmt, (path, time.perf_counter() - start)

    # The writers spend most of their time in NumPy's, zlib's and hashlib's C code, which release
    # the GIL, so writing the formats side by side uses both cores (the 3MF compresses its model
    # on a helper thread of its own while formatting it: threemf.write_in_order).
    # A batch worker with one core to itself (TAMP_THREADS=1) writes them one after the other.
    if mesh.n_triangles > PARALLEL_WRITE_TRIANGLES and len(formats) > 1 and os.environ.get("TAMP_THREADS") != "1":
        if {"obj", "ply"} & set(formats):
            # trimesh's modules import each other: two writer threads importing it at once met a module
            # half made (ImportError: partially initialized module 'trimesh.exchange.ply'), so it is
            # imported here, once, before them
            import trimesh  # noqa: F401
        pool = ThreadPoolExecutor(max_workers=min(len(formats), os.cpu_count() or 1))
        try:
            futures = [pool.submit(write, fmt) for fmt in formats]
            if check is not None:
                gate.run(check)
            return dict(future.result() for future in futures)
        finally:  # stopped (Ctrl-C, SIGTERM) or refused: the formats not begun are not begun; those begun remove their parts
            gate.close()  # unless the check has passed, a writer still waiting removes its part
            pool.shutdown(wait=True, cancel_futures=True)
    if check is not None:
        gate.run(check)
    return dict(write(fmt) for fmt in formats)


class _Gate:
    """A check that writers wait for before their files take their names (write_meshes)."""

    def __init__(self):
        self.done, self.error = threading.Event(), None

    def run(self, check: Callable[[], None]) -> None:
        """Run `check` (once: later calls do nothing) and open the gate; its error, if any, is
        raised here and in every writer waiting."""
        if self.done.is_set():
            return
        try:
            check()
        except BaseException as exc:
            self.error = exc
            raise
        finally:
            self.done.set()

    def close(self) -> None:
        """Open the gate for good: writers waiting fail unless the check has passed."""
        if not self.done.is_set():
            self.error = self.error or ExportError("stopped before the check of the mesh")
            self.done.set()

    def wait(self) -> None:
        self.done.wait()
        if self.error is not None:
            raise ExportError("not written: the check of the mesh failed") from None


@functools.lru_cache(maxsize=1)
def dependency_versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, distribution

    out = {}
    for name in ("numpy", "scipy", "scikit-image", "tifffile", "pillow", "trimesh", "manifold3d"):
        try:
            out[name] = _version_of(distribution(name))
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


def _version_of(dist) -> str:
    """`dist.version`, read from the metadata's header lines: `version()` parses the whole file as
    e-mail (about 5 ms a package, a tenth of writing the files at Medium)."""
    text = dist.read_text("METADATA") or dist.read_text("PKG-INFO") or ""
    for line in text.splitlines():
        if not line.strip():
            break  # the headers end at the first blank line
        if line.lower().startswith("version:"):
            return line.split(":", 1)[1].strip()
    return dist.version


def file_sha256(path: Path) -> str:
    """SHA-256 of a file, read in blocks (of an OME-Zarr folder: its files, as read.py hashes it);
    of a mesh this process has just written, the hash taken while writing it (export.files.written_sha256)."""
    if Path(path).is_dir():
        from ..read.model import sha256_of

        return sha256_of(Path(path))
    known = written_sha256(path)  # a mesh hashed as it was written, unchanged since: not read back
    if known is not None:
        return known
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def recipe_dict(litho, files: list[str]) -> dict:
    src = litho.picture.file
    recipe = {
        "tamp_os_version": __version__,
        "input": {"name": src.name, "path": src.path, "sha256": src.sha256},
        "params": (getattr(litho, "recipe_params", None) or litho.params).to_dict(),
        "outputs": files,
        "print": litho.report.print.as_dict() if litho.report.print else None,
        "relief": {"style": litho.report.relief_style, "reason": litho.report.relief_reason,
                   "legibility": litho.report.legibility.as_dict() if litho.report.legibility else None},
        "versions": dict(dependency_versions()),
        "printer_profile": litho.printer.as_dict(),
    }
    if litho.report.key:  # a channel print's key (issue 22); other recipes are unchanged
        recipe["relief"]["key"] = litho.report.as_dict()["key"]
    return recipe


def write_recipe(litho, path: Path, files: list[str], *, changes: dict | None = None) -> Path:
    """The recipe of `litho` listing `files`, with `changes` made to its entries (a key given None
    is left out: a figure's own recipe, figure.py)."""
    recipe = recipe_dict(litho, files)
    for key, value in (changes or {}).items():
        if value is None:
            recipe.pop(key, None)
        else:
            recipe[key] = value
    # Each output's hash, so a resume knows the set is this run's whole set (not a file of the
    # same name from another run, or one damaged since).
    recipe["output_sha256"] = {name: file_sha256(path.parent / name) for name in files if (path.parent / name).is_file()}
    if recipe["input"]["path"]:  # also relative to the recipe, so a moved folder still rebuilds
        recipe["input"]["path_from_recipe"] = os.path.relpath(os.path.abspath(recipe["input"]["path"]), os.path.abspath(path.parent))
    return write_text(path, json.dumps(recipe, indent=2, ensure_ascii=False) + "\n")


def load_recipe(path) -> tuple[Path, LithoParams, PrinterProfile | None, dict]:
    """(input path, params, printer profile, recipe) from a recipe; the input must still hash the same.

    Only the input the recipe names is opened (beside the recipe, by its path relative to the
    recipe, or by its recorded path), only if it is a regular file, and never quoted in an error.
    """
    path = Path(path)
    recipe = _read_recipe(path)
    info = recipe["input"]
    try:
        params = LithoParams.from_dict(recipe["params"])
        profile = PrinterProfile.from_dict(recipe["printer_profile"]) if recipe.get("printer_profile") else None
    except (TypeError, AttributeError) as exc:
        raise InputError(f"{path}: not a usable TAMP-OS recipe ({exc.__class__.__name__} in its parameters).") from None
    except ParameterError as exc:  # a bad value inside the file: the file is the problem (exit 1), named by its own keys
        raise InputError(f"{path}: {exc}", in_file=True) from None
    candidates = [Path(info["path"])] if info.get("path") else []
    if info.get("path_from_recipe"):
        candidates.insert(0, Path(os.path.normpath(path.parent / info["path_from_recipe"])))
    candidates.append(path.parent / info["name"])
    for image in candidates:
        if image.is_file():
            try:
                digest = file_sha256(image)
            except OSError as exc:
                raise InputError(
                    f"{path}: its input {image} cannot be read ({exc.strerror}); check its permissions and run again."
                ) from None
            if digest != info["sha256"]:
                raise InputError(
                    f"{path}: the input {image} has changed since the recipe was written (SHA-256 differs); "
                    f"the same output cannot be rebuilt from it."
                )
            return image, params, profile, recipe
    raise InputError(f"{path}: its input {info['name']} was not found at {', '.join(map(str, candidates))}.")


def _read_recipe(path: Path) -> dict:
    """The recipe's JSON, checked for the fields a rebuild needs (the file's text is never echoed)."""
    bad = f"{path}: not a readable TAMP-OS recipe"
    if not path.is_file():
        raise InputError(f"{path}: no such recipe file (or not a regular file).")
    if path.stat().st_size > 10_000_000:
        raise InputError(f"{bad} (larger than 10 MB; a recipe is a few kB).")
    try:
        recipe = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"{bad} ({exc.strerror}).") from None
    except (ValueError, RecursionError):  # not UTF-8 JSON, or nested too deeply to be ours
        raise InputError(f"{bad} (not the JSON a recipe holds).") from None
    info = recipe.get("input") if isinstance(recipe, dict) else None
    if not isinstance(info, dict) or not isinstance(recipe.get("params"), dict):
        raise InputError(f"{bad} (it needs an 'input' record and 'params').")
    name, digest = info.get("name"), info.get("sha256")
    if not isinstance(name, str) or not name or Path(name).name != name:
        raise InputError(f"{bad} (its input 'name' must be a plain file name).")
    if not isinstance(digest, str) or len(digest) != 64 or any(c not in "0123456789abcdef" for c in digest):
        raise InputError(f"{bad} (its input needs a 'sha256' of 64 hexadecimal digits).")
    for key in ("path", "path_from_recipe"):
        if info.get(key) is not None and not isinstance(info[key], str):
            raise InputError(f"{bad} (its input '{key}' must be text).")
    return recipe


def recipe_outputs_if_current(recipe_path: Path, source: Path, params: LithoParams) -> list[str] | None:
    """The files an existing recipe lists, if it records this input and these parameters and
    every file it lists is still there with the SHA-256 the recipe recorded; else None (the
    input must be converted again)."""
    try:
        recipe = json.loads(recipe_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(recipe, dict) or recipe.get("params") != params.to_dict():
        return None
    try:
        digest = file_sha256(source)
    except OSError:
        return None
    if (recipe.get("input") or {}).get("sha256") != digest:
        return None
    outputs = recipe.get("outputs", [])
    hashes = recipe.get("output_sha256")
    if not outputs or not isinstance(hashes, dict) or set(hashes) != set(outputs):
        return None  # written before outputs were hashed, or not by TAMP-OS: convert again
    for name in outputs:
        try:
            if file_sha256(recipe_path.parent / name) != hashes[name]:
                return None  # missing, changed, or another run's file of the same name
        except OSError:
            return None
    return outputs + [recipe_path.name]


def save_outputs(litho, target, formats=None, *, stem: str | None = None) -> tuple[list[Path], object]:
    """Save a lithograph's files and, when its parameters ask for G-code, slice it and rewrite the
    recipe with the result. Returns the paths written (recipe last) and the lithograph whose report
    says so (a new report: the old one is not changed)."""
    written = save(litho, target, formats, stem=stem)
    if not litho.params.gcode:
        return written, litho
    written, result = slice_outputs(litho, written)
    sliced = dataclasses.replace(litho, report=litho.report.with_printing(Printing(result, Path(result.gcode).name)))
    recipe = written[-1]
    assert recipe.name.endswith(RECIPE_SUFFIX)
    write_recipe(sliced, recipe, [p.name for p in written[:-1]])
    return written, sliced


def slice_outputs(litho, written: list[Path]) -> tuple[list[Path], SliceResult]:
    """Slice a saved lithograph with PrusaSlicer: its STL (written first when `written` has none)
    becomes NAME.gcode beside it. Returns the paths now written (recipe last, not yet rewritten)
    and what slicing found; save_outputs makes the new report and recipe from them."""
    from ..printing.slicer import material_for, slice_mesh

    recipe = next(p for p in written if p.name.endswith(RECIPE_SUFFIX))
    others = [p for p in written if p != recipe]
    stl = next((p for p in others if p.suffix == ".stl"), None)
    if stl is None:
        stl = save_mesh(litho.mesh, recipe.parent / (recipe.name[: -len(RECIPE_SUFFIX)] + ".stl"), metadata(litho))
        others.append(stl)
    params = litho.params
    mat = material_for(litho.printer, params.material, filament_price_per_kg=params.filament_price_per_kg,
                       resin_price_per_kg=params.resin_price_per_kg)
    result = slice_mesh(stl, litho.printer, mat, timeout_s=params.slice_timeout_s)
    others.append(Path(result.gcode))
    return others + [recipe], result
