"""A 3-D model standing on a base plate that carries the furniture (braille caption, scale bar,
orientation corner), fused into one solid.

The model's footprint (its x–y extent) takes the place a relief has on a plate: `plan_furniture`
lays out the plate around a `width_mm` × `depth_mm` footprint, the model stands on the plate with
its lowest `sink_mm` inside it (parts overlap, never touch), and one manifold3d union joins them,
minus the cut corner at the top right. Parts of the model that do not reach down to the base
float: `stand_model` counts them, so the report can say so.
"""

from __future__ import annotations

from dataclasses import dataclass

from .furniture import SEAM_MM, Furniture, Placed, build_raised, fuse_solid, plan_furniture

SINK_MM = 0.5  # the model reaches this far into the plate
POST_RADIUS_MM = 1.2  # a post that holds a floating part up: 2.4 mm across, thicker than any wall minimum
POST_SEGMENTS = 24


@dataclass
class Stand:
    """The fused solid and where everything went."""

    solid: object  # manifold3d.Manifold
    placed: Placed
    base_mm: float
    model_offset_mm: tuple[float, float, float]  # added to the model's coordinates
    floating: int  # parts of the model that do not reach the base
    parts: int  # parts of the model
    posts: int = 0  # floating parts held up by a post (those with a clear way straight down)


def stand_model(model, width_mm: float, depth_mm: float, *, base_mm: float, furniture: Furniture, with_posts: bool = True) -> Stand:
    """`model` (a manifold3d solid whose footprint is [0, width_mm] × [0, depth_mm], its lowest
    point at z = 0) on a base plate `base_mm` thick with the furniture, as one solid."""
    import manifold3d as m3

    plan = plan_furniture(width_mm, depth_mm, furniture)
    placed = plan.placed
    plate_w, plate_d = placed.plate_mm
    plate_top = base_mm - min(SEAM_MM, base_mm / 10)
    plate = m3.Manifold.cube((plate_w, plate_d, plate_top))
    sink = min(SINK_MM, base_mm / 2)
    ox, oy = placed.relief_origin_mm
    offset = (ox, oy, base_mm - sink)
    lifted = model.translate(offset)
    pieces = lifted.decompose()
    above = [p for p in pieces if p.bounding_box()[2] > plate_top]
    posts = [post for post in (post_under(p, lifted, plate_top - sink) for p in above) if post is not None] if with_posts else []
    raised = build_raised(plan, base_mm, furniture.spec)
    top = float(lifted.bounding_box()[5])
    solid = fuse_solid([plate, lifted, *posts, *raised], placed, max(top, base_mm + 2.0))
    return Stand(solid, placed, base_mm, offset, len(above), len(pieces), len(posts))


def furniture_triangles(width_mm: float, depth_mm: float, *, base_mm: float, furniture: Furniture) -> int:
    """The triangles the plate and its raised furniture add to a model of this footprint (before
    their union with it, which adds a seam): what a triangle budget leaves room for."""
    plan = plan_furniture(width_mm, depth_mm, furniture)
    return 12 + sum(int(part.num_tri()) for part in build_raised(plan, base_mm, furniture.spec))


def post_under(piece, model, floor_mm: float):
    """A round post from `floor_mm` (inside the plate) up into the lowest point of `piece`, or None
    when the way straight down from there meets another part of `model` (a post through it would
    join what is apart)."""
    import manifold3d as m3
    import numpy as np

    verts = np.asarray(piece.to_mesh().vert_properties)[:, :3]
    x, y, z = (float(v) for v in verts[int(np.argmin(verts[:, 2]))])
    for dx, dy in ((0, 0), (POST_RADIUS_MM, 0), (-POST_RADIUS_MM, 0), (0, POST_RADIUS_MM), (0, -POST_RADIUS_MM)):
        if model.ray_cast((x + dx, y + dy, z - 0.05), (x + dx, y + dy, floor_mm)):
            return None
    reach = min(SINK_MM, float(verts[:, 2].max() - z) / 2)  # into the part, never through it
    return m3.Manifold.cylinder(z + reach - floor_mm, POST_RADIUS_MM, POST_RADIUS_MM, POST_SEGMENTS).translate((x, y, floor_mm))
