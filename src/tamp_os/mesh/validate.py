"""Check that a mesh is a printable solid: closed, 2-manifold, wound outward, no degenerate faces.

check_solid looks at the mesh by vertex index, as it is held in memory (tests use it; nothing in
the product calls it yet). Independent libraries (trimesh, manifold3d, lib3mf) check the same
things in the test suite.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .solid import Mesh


@dataclass
class SolidCheck:
    closed: bool
    manifold: bool
    outward: bool
    degenerate_faces: int
    volume_mm3: float
    bounds_mm: list
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.closed and self.manifold and self.outward and self.degenerate_faces == 0


def check_solid(mesh: Mesh) -> SolidCheck:
    faces = np.asarray(mesh.faces, dtype=np.int64)
    n = len(mesh.vertices)
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    keys = directed[:, 0] * n + directed[:, 1]
    unique_keys, counts = np.unique(keys, return_counts=True)
    problems = []
    # Each directed edge once (consistent winding, no edge shared by >2 faces) ...
    once = bool((counts == 1).all())
    if not once:
        problems.append(f"{int((counts > 1).sum())} directed edges are used by more than one face")
    # ... and its reverse present (closed, every edge has exactly two faces).
    reverse = directed[:, 1] * n + directed[:, 0]
    closed = bool(np.isin(reverse, unique_keys, assume_unique=False).all())
    if not closed:
        problems.append("the surface has open (boundary) edges")
    tri = mesh.vertices[faces]
    areas2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    degenerate = int((areas2 <= 1e-12).sum())
    if degenerate:
        problems.append(f"{degenerate} faces have zero area")
    volume = mesh.volume_mm3()
    outward = volume > 0
    if not outward:
        problems.append("faces wind inward (negative volume)")
    return SolidCheck(
        closed=closed,
        manifold=once and closed,
        outward=outward,
        degenerate_faces=degenerate,
        volume_mm3=volume,
        bounds_mm=mesh.bounds_mm.tolist(),
        problems=problems,
    )
