"""The relief set into its furnished plate without a mesh boolean on the relief (issue 37).

The relief stands on the plate inside the rectangle at its origin, and no furniture comes near
it (every element keeps CLEARANCE_MM), so the union of the relief with the plate is known
without computing it: the plate's top face loses the relief's footprint, and the relief's walls
end on the plate's top. Only the small parts (the plate with a pocket where the relief sits,
the raised furniture, the cut corner) go through manifold3d; the relief's tens of thousands of
triangles are joined to the pocket's rim by splitting the rim's triangles at the relief's wall
points. The solid is the one the boolean of furniture.fuse_solid gives (the same volume and
surface; another triangulation of the plate's top next to the relief).

Anything unexpected (the corner cut reaching the relief, a rim that is not the footprint's
outline, a result that is not a closed, consistently oriented surface) returns None, and the
caller does the boolean.
"""

from __future__ import annotations

import numpy as np

from ..mesh.solid import INDEX, Mesh

SNAP_MM = 1e-4  # a pocket vertex this close to the footprint's outline lies on it (Clipper's rounding)


def inlaid(relief: Mesh, plate: Mesh, origin_mm: tuple[float, float], *, plate_top_mm: float, pocket_floor_mm: float) -> Mesh | None:
    """The relief (its outline [0, w] × [0, d], bottom at z = 0) at `origin_mm` on `plate`: the
    furnished plate (the corner already cut) with a pocket under the relief's footprint from
    `pocket_floor_mm` up through its top at `plate_top_mm`. None when they do not fit together."""
    box = _footprint(relief, origin_mm)
    vertices = plate.vertices.astype(np.float32)
    top = np.float32(plate_top_mm)
    faces = _without_pocket(vertices, plate.faces, box, (np.float32(pocket_floor_mm), top))
    if faces is None:
        return None
    vertices = _snapped(vertices, box, top)
    if (relief.vertices[relief.vertices[:, 2] > 0.0, 2] <= plate_top_mm + SNAP_MM).any():
        return None  # a top surface down at the plate's top: its walls would not stand on the rim
    relief_vertices, relief_faces, foot = _relief_above(relief, origin_mm, top)
    rim_points = relief_vertices[foot, :2]
    split = _rim_split(vertices, faces, rim_points, box, top)
    if split is None:
        return None
    extra, faces = split
    joined = _joined((np.concatenate([vertices, extra]), faces), (relief_vertices, relief_faces), foot)
    if joined is None or not closed_and_oriented(joined[1]):
        return None
    return Mesh(vertices=joined[0].astype(np.float64), faces=joined[1].astype(INDEX))


def _footprint(relief: Mesh, origin_mm) -> np.ndarray:
    """(x0, y0, x1, y1) of the relief's outline on the plate, in float32 (the meshes' precision)."""
    x, y = relief.vertices[:, 0], relief.vertices[:, 1]  # by column: min(axis=0) over (N, 3) rows is ~20x slower
    return np.array([x.min() + origin_mm[0], y.min() + origin_mm[1], x.max() + origin_mm[0], y.max() + origin_mm[1]], np.float32)


def _without_pocket(vertices: np.ndarray, faces: np.ndarray, box: np.ndarray, heights) -> np.ndarray | None:
    """The plate's faces without the pocket's walls and floor (every face whose centre lies in
    the footprint between the pocket's floor and the plate's top, `heights`); None when no
    pocket is there."""
    floor, top = heights
    centre = vertices[faces].mean(axis=1)
    inside = ((centre[:, 0] >= box[0] - SNAP_MM) & (centre[:, 0] <= box[2] + SNAP_MM) & (centre[:, 1] >= box[1] - SNAP_MM)
              & (centre[:, 1] <= box[3] + SNAP_MM) & (centre[:, 2] >= floor - SNAP_MM) & (centre[:, 2] < top - SNAP_MM))  # fmt: skip
    if not inside.any():
        return None
    return faces[~inside]


def _snapped(vertices: np.ndarray, box: np.ndarray, top: np.float32) -> np.ndarray:
    """Vertices of the plate's top on the footprint's outline put exactly on it (x or y equal to
    the outline's, as the relief's wall points are)."""
    out = vertices.copy()
    on_top = out[:, 2] == top
    for axis, values in ((0, box[[0, 2]]), (1, box[[1, 3]])):
        other = out[:, 1 - axis]
        along = (other >= box[1 - axis] - SNAP_MM) & (other <= box[3 - axis] + SNAP_MM)  # within the side's span
        for value in values:
            near = on_top & along & (np.abs(out[:, axis] - value) <= SNAP_MM)
            out[near, axis] = value
    return out


def _relief_above(relief: Mesh, origin_mm, top: np.float32) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The relief on the plate from its top down: (vertices, faces without the floor, which
    vertices are the wall's foot). The foot (z = 0) is lifted to the plate's top, the floor goes."""
    vertices = (relief.vertices + np.array([*origin_mm, 0.0])).astype(np.float32)
    foot = relief.vertices[:, 2] <= 0.0  # close_top puts the bottom at exactly z = 0
    vertices[foot, 2] = top
    faces = np.asarray(relief.faces, dtype=np.int64)
    corners = np.take(foot, faces)  # (np.take and &: the same as foot[faces].all(axis=1), several times sooner)
    faces = faces[~(corners[:, 0] & corners[:, 1] & corners[:, 2])]  # the floor: a fan of foot points around its centre
    used = np.zeros(len(vertices), bool)
    used[faces.ravel()] = True
    return vertices, faces, foot & used


def _rim_split(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray, box: np.ndarray, top: np.float32) -> tuple[np.ndarray, np.ndarray] | None:
    """(new vertices, faces): the plate's faces with every open edge (the pocket's rim, on the
    footprint's outline) split at the relief's wall foot points between its ends, as a fan from
    the face's third corner, so that no T-junction is left. The new vertices (at those points)
    follow the plate's; None when the open edges are not the outline."""
    edges = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)  # face k: edges 3k .. 3k + 2
    rim = _unpaired(edges)
    ends = vertices[edges[rim]]
    if len(rim) < 4 or not (ends[:, :, 2] == top).all() or not _on_outline(ends[:, :, :2], box).all():
        return None
    keep = np.ones(len(faces), bool)
    added, new_points = [], {}
    for e in rim.tolist():
        k, corner = divmod(e, 3)
        a, b, c = (int(faces[k][(corner + m) % 3]) for m in range(3))
        inner = _between(points, vertices[a, :2], vertices[b, :2])
        if len(inner) == 0:
            continue
        chain = [a] + [new_points.setdefault(p, len(vertices) + len(new_points)) for p in map(tuple, inner.tolist())] + [b]
        keep[k] = False
        added += [(chain[i], chain[i + 1], c) for i in range(len(chain) - 1)]
    extra = np.empty((len(new_points), 3), dtype=np.float32)
    extra[:, :2] = np.array(list(new_points), dtype=np.float32).reshape(-1, 2)
    extra[:, 2] = top
    return extra, np.concatenate([faces[keep], np.array(added, dtype=faces.dtype).reshape(-1, 3)])


def _unpaired(edges: np.ndarray) -> np.ndarray:
    """Indices of the edges (rows of vertex pairs) no other edge shares."""
    low, high = (np.minimum(edges[:, 0], edges[:, 1]).astype(np.int64), np.maximum(edges[:, 0], edges[:, 1]).astype(np.int64))
    keys = low * (int(high.max()) + 1) + high
    # Sorted once (np.unique's inverse and counts cost several sorts' worth): a key is alone when neither neighbour equals it.
    order = np.argsort(keys)
    ordered = keys[order]
    alone = np.ones(len(keys), bool)
    same = ordered[1:] == ordered[:-1]
    alone[1:] &= ~same
    alone[:-1] &= ~same
    single = np.zeros(len(keys), bool)
    single[order[alone]] = True
    return np.flatnonzero(single)


def _on_outline(ends: np.ndarray, box: np.ndarray) -> np.ndarray:
    """Per edge (its two ends' x, y): whether both ends lie on one side of the box."""
    x, y = ends[:, :, 0], ends[:, :, 1]
    return (x == box[0]).all(axis=1) | (x == box[2]).all(axis=1) | (y == box[1]).all(axis=1) | (y == box[3]).all(axis=1)


def _between(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The points on the axis-parallel segment a-b strictly between its ends, from a to b."""
    axis = 0 if a[1] == b[1] else 1  # the coordinate that varies along the segment
    fixed = points[:, 1 - axis] == a[1 - axis]
    lo, hi = min(a[axis], b[axis]), max(a[axis], b[axis])
    along = points[fixed & (points[:, axis] > lo) & (points[:, axis] < hi)]
    order = np.argsort(along[:, axis] if a[axis] < b[axis] else -along[:, axis], kind="stable")
    return along[order]


def _joined(plate: tuple[np.ndarray, np.ndarray], relief: tuple[np.ndarray, np.ndarray], foot: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """One mesh of the plate and the relief, the relief's `foot` vertices (on the plate's top)
    replaced by the plate's vertex at the same place, unused vertices dropped; None when a foot
    vertex has no plate vertex there."""
    (plate_vertices, plate_faces), (relief_vertices, relief_faces) = plate, relief
    top = relief_vertices[foot, 2][0] if foot.any() else None
    at = {p: i for i, p in zip(np.flatnonzero(plate_vertices[:, 2] == top).tolist(), map(tuple, plate_vertices[plate_vertices[:, 2] == top, :2].tolist()))}
    feet = [at.get(p, -1) for p in map(tuple, relief_vertices[foot, :2].tolist())]
    if -1 in feet:
        return None
    renumber = np.arange(len(relief_vertices)) + len(plate_vertices)
    renumber[foot] = feet
    vertices = np.concatenate([plate_vertices, relief_vertices])
    faces = np.concatenate([plate_faces, np.take(renumber, relief_faces)])  # np.take: renumber[relief_faces], sooner
    used = np.zeros(len(vertices), bool)
    used[faces.ravel()] = True
    return vertices[used], np.take(np.cumsum(used) - 1, faces)


def closed_and_oriented(faces: np.ndarray) -> bool:
    """Every edge in exactly two faces, once in each direction, and no face with a repeated vertex."""
    if (faces[:, 0] == faces[:, 1]).any() or (faces[:, 1] == faces[:, 2]).any() or (faces[:, 0] == faces[:, 2]).any():
        return False
    # One sort: edge a->b becomes 2·(min·n + max) + (a < b). The surface is closed and oriented
    # exactly when the sorted keys pair up as (2u, 2u + 1) with every u distinct: each undirected
    # edge once each way (sorting the edges and their reverses, as before, took two sorts).
    n = np.int64(int(faces.max()) + 1)
    m = len(faces)
    keys = np.empty(3 * m, dtype=np.int64)
    for j, (s, d) in enumerate(((0, 1), (1, 2), (2, 0))):
        a, b, part = faces[:, s].astype(np.int64), faces[:, d].astype(np.int64), keys[j * m : (j + 1) * m]
        np.minimum(a, b, out=part)
        part *= n
        part += np.maximum(a, b)
        part *= 2
        part += a < b
    if len(keys) % 2:
        return False  # every edge twice: an even number of them
    keys.sort()
    pairs = keys.reshape(-1, 2)
    return bool((pairs[:, 0] % 2 == 0).all() and (pairs[:, 1] == pairs[:, 0] + 1).all() and (pairs[1:, 0] > pairs[:-1, 1]).all())
