"""Every output format, once: its kind, file suffixes, writer, check, size estimate and whether it
can hold the parts of a two-colour print. Every list of formats (parameters, CLI help, the web
form, presets, multi-part writing, rendering, mesh readers) reads this table.

A foundation module: writers and checks are named as "module:function" inside `tamp_os.export`
and imported only when a file is written, so reading the table costs nothing.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Callable, Literal


@dataclass(frozen=True)
class Format:
    name: str  # as the parameter `formats` takes it: "stl"
    kind: Literal["mesh", "graphic", "pins", "document"]  # a 3-D solid, a 2-D tactile graphic (swell paper, embosser), pin-display pages, or a document about the plate
    suffixes: tuple[str, ...]  # file suffixes, the first is written: (".step", ".stp")
    purpose: str  # for people, one plain sentence of what the file is for ("For any slicer: ..."); the CLI's
    # the command line's help, the web form, the web app's file list and README.txt, and the README's table (a test) read it
    writer: str | None = None  # "stl:write_stl" in tamp_os.export (meshes); graphics are drawn by export.tactile2d
    check: str | None = None  # "step:check_step": raises ExportError when the format cannot hold a mesh
    bytes_per_triangle: float = 0.0  # size estimate: fixed + per triangle + per vertex (measured on our own files)
    bytes_per_vertex: float = 0.0
    bytes_fixed: float = 0.0
    holds_parts: bool = False  # can carry a two-colour print's parts (3MF: objects; STL: one file per part)
    readable: bool = False  # our mesh reader (trimesh) reads it back: render, check and slice accept it

    @property
    def suffix(self) -> str:
        return self.suffixes[0]

    @property
    def estimated(self) -> bool:
        return self.kind == "mesh"

    def estimate_bytes(self, triangles: int, vertices: int) -> int | None:
        """About how large the file will be; None for graphics (their size follows the page, not the mesh)."""
        if not self.estimated:
            return None
        return int(self.bytes_fixed + self.bytes_per_triangle * triangles + self.bytes_per_vertex * vertices)

    def write_function(self) -> Callable:
        return _resolve(self.writer)

    def check_function(self) -> Callable | None:
        return _resolve(self.check) if self.check else None


def _resolve(spec: str) -> Callable:
    module, function = spec.split(":")
    return getattr(importlib.import_module(f"tamp_os.export.{module}"), function)


TABLE: tuple[Format, ...] = (
    Format("stl", "mesh", (".stl",), "For any slicer: the closed solid to print, in millimetres.", "stl:write_stl", bytes_fixed=84, bytes_per_triangle=50,
           holds_parts=True, readable=True),
    Format("3mf", "mesh", (".3mf",), "For your slicer (PrusaSlicer, Bambu Studio, OrcaSlicer, Cura): the solid with its units, description and print settings inside.",
           "threemf:write_3mf", bytes_fixed=2000, bytes_per_triangle=7, bytes_per_vertex=9, holds_parts=True, readable=True),
    Format("glb", "mesh", (".glb",), "For a 3-D view in a web browser or any glTF viewer: the solid to turn and look at.", "glb:write_glb", bytes_fixed=1500,
           bytes_per_triangle=12, bytes_per_vertex=24, readable=True),
    Format("obj", "mesh", (".obj",), "For 3-D programs that read Wavefront OBJ: the solid.", "plain:write_obj", bytes_per_triangle=30,
           bytes_per_vertex=40, readable=True),
    Format("ply", "mesh", (".ply",), "For 3-D programs that read PLY: the solid.", "plain:write_ply", bytes_fixed=300, bytes_per_triangle=13,
           bytes_per_vertex=12, readable=True),
    Format("step", "mesh", (".step", ".stp"), "For CAD programs: the solid as one faceted STEP body.", "step:write_step",
           "step:check_step", bytes_fixed=5000, bytes_per_triangle=800),
    Format("pdf", "graphic", (".pdf",), "For swell paper or a braille embosser: the plate as a flat tactile graphic at its real size."),
    Format("svg", "graphic", (".svg",), "For swell paper, an embosser or a drawing program: the plate as a flat tactile graphic, to print or edit."),
    # refreshable pin displays (issue 34): pages drawn by export.pins, written by export.pin_files
    Format("dotpad", "pins", (".dtms",), "For the Dot Pad 320 pin display: the plate as pages of raised pins (overview, zooms and key) with a braille line."),
    Format("graphiti", "pins", (".graphiti",), "For the Graphiti and Graphiti Plus pin displays: the plate as pages of pins at five heights, each page also as a PNG picture."),
    Format("monarch", "pins", (".monarch.svg",), "For the Monarch pin display: the plate as pages of 96 × 40 pins, one SVG file a page."),
    # documents about the plate (issue 35): written by export.ebraille and export.tour
    Format("ebraille", "document", (".ebrl",), "For eBraille readers and braille displays: a book with the braille text, the tactile graphic (SVG and PDF) and a touch tour."),
    Format("tour", "document", (".tour.html",), "For a tablet beside or under the plate: a touch tour, one web page that says what each region is when a finger touches it."),
)
BY_NAME: dict[str, Format] = {f.name: f for f in TABLE}
NAMES: tuple[str, ...] = tuple(BY_NAME)
MESH_FORMATS: tuple[str, ...] = tuple(f.name for f in TABLE if f.kind == "mesh")
GRAPHIC_FORMATS: tuple[str, ...] = tuple(f.name for f in TABLE if f.kind == "graphic")
PIN_FORMATS: tuple[str, ...] = tuple(f.name for f in TABLE if f.kind == "pins")
DOCUMENT_FORMATS: tuple[str, ...] = tuple(f.name for f in TABLE if f.kind == "document")
# Meshes we read back (render, check, slice, estimate): ours plus two that trimesh reads too.
READABLE_MESH_SUFFIXES: tuple[str, ...] = tuple(f.suffix for f in TABLE if f.readable) + (".gltf", ".off")


def by_suffix(suffix: str) -> Format | None:
    """The format a file suffix names ('.stp' is step), or None."""
    suffix = suffix.lower() if suffix.startswith(".") else "." + suffix.lower()
    return next((f for f in TABLE if suffix in f.suffixes), None)


def estimate_bytes(name: str, triangles: int, vertices: int) -> int | None:
    return BY_NAME[name].estimate_bytes(triangles, vertices)
