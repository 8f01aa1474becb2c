"""A closed surface within a triangle budget, and what that cost: deviation and wall thickness.

- `to_manifold` / `from_manifold` move a Mesh into manifold3d and back (manifold3d keeps every
  result closed and 2-manifold);
- `meet_budget` simplifies with manifold3d's `simplify(tolerance)` (edge collapses that move no
  surface by more than about the tolerance), the tolerance found by bisection: the smallest that
  leaves at most `max_triangles`, kept when the measured deviation stays within `max_deviation_mm`;
- `surface_deviation` measures, independently of the simplifier, the largest distance between two
  surfaces at sampled points, both ways (point to nearest triangle, exactly);
- `wall_thickness` casts a ray inward from sampled surface points (along the inward normal) and
  returns the distance to the surface on the other side: the wall a finger or a nozzle meets there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .solid import INDEX, Mesh

BISECTIONS = 5  # halvings of the tolerance interval: within 1/32 of it


@dataclass
class Budget:
    """What meeting the budget did."""

    triangles_before: int
    triangles: int
    tolerance_mm: float  # the simplifier's tolerance used (0: not simplified)
    met: bool
    deviation_mm: float = 0.0  # measured between the full surface and the result (0: not simplified)
    within: bool = True  # the deviation is within the limit asked (False only when the budget was kept instead)
    budget_tolerance_mm: float = 0.0  # unmet: the tolerance that would meet the budget, and how far that moves the surface
    budget_deviation_mm: float = 0.0


def to_manifold(mesh: Mesh):
    import manifold3d as m3

    return m3.Manifold(m3.Mesh(vert_properties=np.ascontiguousarray(mesh.vertices, dtype=np.float32),
                               tri_verts=np.ascontiguousarray(mesh.faces, dtype=np.uint32)))


def from_manifold(solid) -> Mesh:
    out = solid.to_mesh()
    return Mesh(np.asarray(out.vert_properties, dtype=np.float64)[:, :3].copy(), np.asarray(out.tri_verts, dtype=INDEX).copy())


def meet_budget(solid, max_triangles: int, max_deviation_mm: float, *, reference: Mesh | None = None):
    """(the solid simplified to at most `max_triangles`, Budget), never further from `reference`
    (the full surface) than `max_deviation_mm` as measured by `surface_deviation`.

    The smallest tolerance that meets the budget is found by bisection (`tolerance_for`); kept when its
    measured deviation is within the limit. Else the budget cannot be met within it: the largest
    tolerance whose measured deviation stays within the limit is kept (the budget then unmet), and
    the Budget says what meeting it would have cost.
    """
    before = int(solid.num_tri())
    if before <= max_triangles:
        return solid, Budget(before, before, 0.0, True)
    reference = reference if reference is not None else from_manifold(solid)
    candidate, tolerance, measured = simplify_to_budget(solid, max_triangles, reference, start_mm=max_deviation_mm)
    if measured <= max_deviation_mm and candidate.num_tri() <= max_triangles:
        return candidate, Budget(before, int(candidate.num_tri()), tolerance, True, measured)
    best, used, deviation = largest_within(solid, reference, min(tolerance, max_deviation_mm), max_deviation_mm=max_deviation_mm)
    return best, Budget(before, int(best.num_tri()), used, int(best.num_tri()) <= max_triangles, deviation,
                        budget_tolerance_mm=tolerance, budget_deviation_mm=measured)


def simplify_to_budget(solid, max_triangles: int, reference: Mesh, *, start_mm: float):
    """(the solid simplified by the smallest tolerance that leaves at most `max_triangles`, that
    tolerance, its measured deviation from `reference`)."""
    tolerance, candidate = _search(solid, max_triangles, start_mm)
    return candidate, tolerance, surface_deviation(reference, from_manifold(candidate))


def largest_within(solid, reference: Mesh, most_mm: float, *, max_deviation_mm: float):
    """(the solid simplified by the largest tolerance up to `most_mm` whose measured deviation from
    `reference` is within `max_deviation_mm`, by bisection; that tolerance (0: none); its deviation)."""
    best, used, deviation = solid, 0.0, 0.0
    lo, hi = 0.0, most_mm
    for _ in range(BISECTIONS):
        middle = (lo + hi) / 2
        candidate = solid.simplify(middle)
        measured = surface_deviation(reference, from_manifold(candidate))
        if measured <= max_deviation_mm:
            best, used, deviation, lo = candidate, middle, measured, middle
        else:
            hi = middle
    return best, used, deviation


def tolerance_for(solid, max_triangles: int, start_mm: float, *, most_mm: float = 5.0) -> float:
    """The smallest simplification tolerance (mm) that leaves at most `max_triangles` (manifold3d's
    edge collapses: fewer triangles as the tolerance grows), to within FILL of the budget or 1/32 of
    the tolerance; `most_mm` when none does.

    Each try is a simplification of the whole surface, so the tries are few: the next tolerance is
    read off the count's power law in the tolerance (a straight line in log–log through the last two
    tries, or between the closest tries either side of the budget), not halved blindly.
    """
    return _search(solid, max_triangles, start_mm, most_mm=most_mm)[0]


def _search(solid, max_triangles: int, start_mm: float, *, most_mm: float = 5.0):
    """`tolerance_for`'s search: (the tolerance, the solid simplified by it)."""
    made = {}

    def count(t: float) -> int:
        made[t] = solid.simplify(t)
        return int(made[t].num_tri())

    def found(t: float):
        return t, made[t] if t in made else solid.simplify(t)

    aim = max_triangles * (1 - FILL / 2)
    lo, n_lo = 0.0, int(solid.num_tri())  # the largest tolerance known to leave too many
    hi, n_hi = None, 0  # the smallest known to fit
    tries: list[tuple[float, int]] = []
    t = float(start_mm)
    for _ in range(MAX_TRIES):
        n = count(t)
        tries.append((t, n))
        if n <= max_triangles:
            hi, n_hi = t, n
        else:
            lo, n_lo = t, n
        if hi is not None and (n_hi >= max_triangles * (1 - FILL) or hi - lo <= hi / 32):
            return found(hi)
        if hi is None and t >= most_mm:
            return found(most_mm)
        t = _next_tolerance(tries, lo, n_lo, hi, n_hi, aim, most_mm)
        for old in [k for k in made if k not in (lo, hi)]:
            del made[old]  # only the two ends are kept
    return found(hi if hi is not None else most_mm)


FILL = 0.03  # a tolerance whose count fills the budget to within this share is the one
MAX_TRIES = 10


def _next_tolerance(tries, lo, n_lo, hi, n_hi, aim: float, most_mm: float) -> float:
    """The next tolerance to try: where the power law through the closest tries meets `aim`, kept
    inside what is known (above `lo`, below `hi`)."""
    import math

    if hi is not None and lo > 0 and n_lo > n_hi > 0:  # both sides known: interpolate in log-log
        f = (math.log(n_lo) - math.log(aim)) / (math.log(n_lo) - math.log(n_hi))
        t = math.exp(math.log(lo) + min(max(f, 0.1), 0.9) * (math.log(hi) - math.log(lo)))
        return t
    (t1, n1) = tries[-1]
    slope = 1.0  # count ∝ tolerance^-slope: about 1 for a curved surface
    if len(tries) >= 2:
        t0, n0 = tries[-2]
        if t0 != t1 and n0 > 0 and n1 > 0 and n0 != n1:
            slope = min(max(-(math.log(n1) - math.log(n0)) / (math.log(t1) - math.log(t0)), 0.3), 3.0)
    t = t1 * (max(n1, 1) / aim) ** (1 / slope)
    if hi is None:  # too many so far: go up, by at least half again, within most_mm
        return min(max(t, t1 * 1.5), t1 * 8, most_mm)
    return max(min(t, hi * 0.95), hi / 8)  # all tries fit: come down towards the budget


def sample_surface(mesh: Mesh, count: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(points, unit outward normals of their faces): `count` points spread by area."""
    rng = np.random.default_rng(seed)
    tri = mesh.vertices[mesh.faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(cross, axis=1)
    face = rng.choice(len(area), size=count, p=area / area.sum())
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    t = tri[face]
    points = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    normals = cross[face] / np.where(area[face] == 0, 1.0, area[face])[:, None]
    return points, normals


def _point_triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Exact distance from each point p to its triangle (a, b, c), vectorised (Ericson's regions)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp, cp = p - b, p - c
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    denom = va + vb + vc
    denom = np.where(np.abs(denom) < 1e-30, 1e-30, denom)
    v, w = vb / denom, vc / denom
    closest = a + v[:, None] * ab + w[:, None] * ac  # inside the face
    regions = [
        ((d1 <= 0) & (d2 <= 0), lambda: a),
        ((d3 >= 0) & (d4 <= d3), lambda: b),
        ((d6 >= 0) & (d5 <= d6), lambda: c),
    ]
    with np.errstate(divide="ignore", invalid="ignore"):
        edge_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
        t_ab = np.clip(d1 / (d1 - d3), 0, 1)
        edge_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
        t_ac = np.clip(d2 / (d2 - d6), 0, 1)
        edge_bc = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
        t_bc = np.clip((d4 - d3) / ((d4 - d3) + (d5 - d6)), 0, 1)
    closest = np.where(edge_bc[:, None], b + np.nan_to_num(t_bc)[:, None] * (c - b), closest)
    closest = np.where(edge_ac[:, None], a + np.nan_to_num(t_ac)[:, None] * ac, closest)
    closest = np.where(edge_ab[:, None], a + np.nan_to_num(t_ab)[:, None] * ab, closest)
    for where, corner in regions[::-1]:
        closest = np.where(where[:, None], corner(), closest)
    return np.linalg.norm(p - closest, axis=1)


def distance_to_surface(points: np.ndarray, mesh: Mesh) -> np.ndarray:
    """Exact distance from each point to `mesh` (the nearest point of any triangle).

    An upper bound first (the nearest of the triangles whose centres are nearest), then every triangle
    that could be nearer: each triangle lies within its bounding sphere (centre, radius r), so only
    those with |p − centre| ≤ bound + r are measured, found by a k-d tree per class of radius (the
    long thin triangles of a simplified mesh in classes of their own).
    """
    from scipy.spatial import cKDTree

    tri = mesh.vertices[mesh.faces]
    centre = tri.mean(axis=1)
    radius = np.linalg.norm(tri - centre[:, None, :], axis=2).max(axis=1)
    tree = cKDTree(centre)
    k = min(8, len(tri))
    _, idx = tree.query(points, k=k)
    idx = idx.reshape(len(points), k)
    best = np.full(len(points), np.inf)
    for j in range(k):
        f = tri[idx[:, j]]
        np.minimum(best, _point_triangle_distance(points, f[:, 0], f[:, 1], f[:, 2]), out=best)
    base = max(float(np.median(radius)), 1e-9)
    classes = np.maximum(0, np.ceil(np.log2(np.maximum(radius / base, 1e-12)))).astype(int)
    for c in np.unique(classes):
        members = np.flatnonzero(classes == c)
        reach = float(radius[members].max())
        sub = cKDTree(centre[members])
        for start in range(0, len(points), 5000):
            chunk = points[start:start + 5000]
            found = sub.query_ball_point(chunk, best[start:start + 5000] + reach)
            counts = np.fromiter((len(x) for x in found), dtype=np.int64, count=len(found))
            if not counts.sum():
                continue
            who = np.repeat(np.arange(len(chunk)), counts)
            faces = members[np.concatenate([np.asarray(x, dtype=np.int64) for x in found if x])]
            f = tri[faces]
            d = _point_triangle_distance(chunk[who], f[:, 0], f[:, 1], f[:, 2])
            here = best[start:start + 5000]
            np.minimum.at(here, who, d)
    return best


def surface_deviation(reference: Mesh, other: Mesh, samples: int = 10_000) -> float:
    """The largest distance, both ways, between sampled points of each surface and the other surface (mm)."""
    ours, _ = sample_surface(other, samples, seed=1)
    theirs, _ = sample_surface(reference, samples, seed=2)
    there = np.concatenate([theirs, reference.vertices[:: max(1, len(reference.vertices) // samples)]])
    return float(max(distance_to_surface(ours, reference).max(), distance_to_surface(there, other).max()))


def wall_thickness(solid, points: np.ndarray, normals: np.ndarray, *, reach_mm: float) -> np.ndarray:
    """The wall behind each surface point: the distance along the inward normal to the first surface
    met, or `reach_mm` when none is met within it.

    Embree (embreex, through trimesh) casts all rays in one call: 5,000 rays on a 124,000-triangle
    model take 0.1 s, where manifold3d's exact ray cast, one Python call a point, takes 13 s; without
    embreex that cast is the fallback. Embree works in single precision on the model scaled to a
    unit box (about 1e-5 mm on a 100 mm model), far below any wall that matters.
    """
    start = points - normals * RAY_START_MM
    try:
        from trimesh.ray.ray_pyembree import RayMeshIntersector
    except ImportError:  # embreex not installed (a platform without its wheels)
        return _wall_by_manifold(solid, start, normals, reach_mm)
    import trimesh

    mesh = from_manifold(solid)
    shape = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    hits, rays, _ = RayMeshIntersector(shape).intersects_location(start, -normals, multiple_hits=True)
    distance = np.linalg.norm(hits - start[rays], axis=1)
    out = np.full(len(points), np.inf)
    ahead = distance > RAY_SELF_MM  # the ray's own triangle, met again at the start, is no wall
    np.minimum.at(out, rays[ahead], distance[ahead])
    return np.minimum(out + RAY_START_MM, float(reach_mm))


RAY_START_MM = 1e-4  # rays start this far inside the surface, off the point's own triangle
RAY_SELF_MM = 1e-5  # a hit this close to a ray's start is its own triangle (Embree's precision on a 100 mm model)


def _wall_by_manifold(solid, start: np.ndarray, normals: np.ndarray, reach_mm: float) -> np.ndarray:
    out = np.full(len(start), float(reach_mm))
    end = start - normals * (reach_mm - RAY_START_MM)
    for i in range(len(start)):
        hits = solid.ray_cast(tuple(start[i]), tuple(end[i]))
        if hits:
            out[i] = RAY_START_MM + hits[0].distance * (reach_mm - RAY_START_MM)
    return out
