"""Two-colour prints: the plate with its relief as one part, the raised furniture as another.

The furniture (braille dots, scale bar, frame) is built as for a one-colour print, then the base
is subtracted from it: the raised part sits on the plate's top and in its own cut-outs, sharing
faces with the base but no volume, so a slicer fills every point of the print from exactly one
extruder. Each part is a closed solid on its own (checked as written before any file is).
"""

from __future__ import annotations

from dataclasses import dataclass

from .furniture import BAR_HEIGHT_MM, FRAME_HEIGHT_MM, Furniture, Placed, relief_part, build_base, build_raised, fuse_solid, plan_furniture, to_mesh
from ..mesh.solid import Mesh

# Colours a reader with low vision tells apart best on a light plate: white base, black raised.
BASE_COLOUR_RGB = (245, 245, 245)
RAISED_COLOUR_RGB = (20, 20, 20)


@dataclass(frozen=True)
class Part:
    """One single-colour solid of a multi-part print (mm); `name` goes into file names (NAME.base.stl)."""

    name: str
    label: str  # what a reader or a slicer's object list calls it
    mesh: Mesh
    colour_rgb: tuple[int, int, int]


KEY_SINK_MM = 0.3  # the key overlay's ground lies this far below the plate's top, so subtracting the base leaves no film


def key_overlay_meshes(heights_mm, overlay_mm, base_mm: float, *, mesh_of) -> tuple[Mesh, Mesh]:
    """(the relief without the key's braille and swatch outlines, a solid of those) for a two-colour print.

    heights_mm : the print's heights (mm, base included), the key strip below the picture.
    overlay_mm : same shape, mm above the base of the second-colour features (0 elsewhere).
    mesh_of : heights -> closed Mesh over the relief's outline (the print's mesher).
    The overlay's ground is sunk below the plate's top; two_colour_parts subtracts the base from it.
    """
    import numpy as np

    on = overlay_mm > 0
    plain = np.where(on, base_mm, heights_mm)
    raised = np.where(on, base_mm + overlay_mm, max(base_mm - KEY_SINK_MM, base_mm / 2))
    return mesh_of(plain), mesh_of(raised)


def two_colour_parts(
    relief: Mesh, width_mm: float, depth_mm: float, *, base_mm: float, furniture: Furniture, overlay: Mesh | None = None
) -> tuple[list[Part], Placed]:
    """The print split into a base part (plate and relief) and a raised part (the furniture).

    Parameters
    ----------
    relief : Mesh
        The relief solid over [0, width_mm] × [0, depth_mm], bottom at z = 0 (mm).
    width_mm, depth_mm, base_mm : float
        The relief's outline and the plate thickness (mm).
    furniture : Furniture
        What to raise. With nothing raised (no caption, scale bar or frame, no key) there is one part.
    overlay : Mesh, optional
        A channel key's braille and swatch outlines over the relief's outline (key_overlay_meshes):
        they go to the raised part, like the caption's braille.

    Returns
    -------
    parts : list of Part
        [base, raised] (or [base] alone); the parts share faces but no volume.
    placed : Placed
        Where each element went, as `add_furniture` returns it.
    """
    plan = plan_furniture(width_mm, depth_mm, furniture) if furniture.wanted else None
    what = "braille, scale bar, frame and the key's braille and outlines" if overlay is not None else "braille, scale bar and frame"
    if plan is None:
        from .furniture import add_furniture

        mesh, placed = add_furniture(relief, width_mm, depth_mm, base_mm=base_mm, furniture=furniture)
        if overlay is None:
            return [Part("base", "plate and relief", mesh, BASE_COLOUR_RGB)], placed
        top = max(float(relief.vertices[:, 2].max()), float(overlay.vertices[:, 2].max()))
        base = fuse_solid([relief_part(relief, (0.0, 0.0), 0.0)], placed, top)
        raised = fuse_solid([relief_part(overlay, (0.0, 0.0), 0.0)], placed, top) - base
        return [
            Part("base", "plate and relief", to_mesh(base), BASE_COLOUR_RGB),
            Part("raised", "the key's braille and outlines", to_mesh(raised), RAISED_COLOUR_RGB),
        ], placed
    placed = plan.placed
    raised_parts = build_raised(plan, base_mm, furniture.spec)
    top = max(float(relief.vertices[:, 2].max()), base_mm + max(BAR_HEIGHT_MM, FRAME_HEIGHT_MM, furniture.spec.dot_height_mm))
    base_parts = build_base(relief, plan, base_mm)
    if overlay is not None:
        top = max(top, float(overlay.vertices[:, 2].max()))
        raised_parts.append(relief_part(overlay, placed.relief_origin_mm, base_mm / 4))
    base = fuse_solid(base_parts, placed, top)
    raised = fuse_solid(raised_parts, placed, top) - base
    return [
        Part("base", "plate and relief", to_mesh(base), BASE_COLOUR_RGB),
        Part("raised", what, to_mesh(raised), RAISED_COLOUR_RGB),
    ], placed


def describe_parts(parts: list[Part]) -> str:
    """A sentence for the description: which part is which colour, and how to print them."""
    if len(parts) < 2:
        return "Two-colour print asked for, but nothing is raised besides the picture (no braille, scale bar or frame): one part."
    return (
        f"Two-colour print: the {parts[0].label} are one part (white) and the {parts[1].label} a second part "
        "(black) resting on it; the 3MF file holds both as one object with two parts, the first set to extruder 1 "
        "and the second to extruder 2 for PrusaSlicer (other slicers: give each part its own filament). "
        "The STL files NAME.base.stl and NAME.raised.stl are the same two parts."
    )
