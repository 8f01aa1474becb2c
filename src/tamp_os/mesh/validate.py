"""Check that a mesh is a printable solid: closed, 2-manifold, wound outward, no degenerate faces.

Two views of the same question:

- `check_solid(mesh)` looks at the mesh by vertex index, as it is held in memory;
- `check_as_written(mesh)` looks at it the way an STL reader and every slicer does: vertices
  rounded to float32 (what STL, 3MF and GLB store) and merged by exact position. Two parts that
  only touch leave two vertex indices at one position; closed by index, pinched once merged.
  The export path runs this check before any file is written.

Independent libraries (trimesh, manifold3d, lib3mf) check the same things in the test suite.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .solid import Mesh

# Smallest face area a written mesh may have: 1e-8 mm² is a 0.1 µm × 0.2 µm triangle, far below
# any printer's resolution but far above the float32 rounding of a zero-area sliver.
MIN_FACE_AREA_MM2 = 1e-8


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


def _check(vertices: np.ndarray, faces: np.ndarray, min_area_mm2: float, collapsed: int = 0) -> SolidCheck:
    """Edge, area and volume checks of (N, 3) float64 mm vertices and (M, 3) int64 faces."""
    n = max(len(vertices), 1)
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    keys = directed[:, 0] * n + directed[:, 1]
    unique_keys, counts = np.unique(keys, return_counts=True)
    problems = []
    # Each directed edge once (consistent winding, no edge shared by >2 faces) ...
    once = bool((counts == 1).all())
    if not once:
        problems.append(f"{int((counts > 1).sum())} directed edges are used by more than one face (pinched or inconsistently wound)")
    # ... and its reverse present (closed, every edge has exactly two faces).
    reverse = directed[:, 1] * n + directed[:, 0]
    open_edges = int((~np.isin(reverse, unique_keys)).sum())
    if open_edges:
        problems.append(f"{open_edges} edges have only one face (the surface is open)")
    tri = vertices[faces]
    areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    degenerate = int((areas <= min_area_mm2).sum()) + collapsed
    if degenerate:
        problems.append(f"{degenerate} faces have an area of at most {min_area_mm2:g} mm² (slivers)")
    volume = float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0) if len(faces) else 0.0
    outward = volume > 0
    if not outward:
        problems.append(f"the volume is {volume:.3g} mm³: faces wind inward or enclose nothing")
    bounds = [vertices.min(axis=0).tolist(), vertices.max(axis=0).tolist()] if len(vertices) else [[], []]
    return SolidCheck(
        closed=open_edges == 0,
        manifold=once and open_edges == 0,
        outward=outward,
        degenerate_faces=degenerate,
        volume_mm3=volume,
        bounds_mm=bounds,
        problems=problems,
    )


def check_solid(mesh: Mesh) -> SolidCheck:
    """The mesh by vertex index: closed, each edge in two faces of opposite direction, outward."""
    # Twice the area at most 1e-12: only faces of exactly (or numerically) zero area.
    return _check(mesh.vertices, np.asarray(mesh.faces, dtype=np.int64), 0.5e-12)


def merge_float32(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices rounded to float32 and merged by exact position, and the faces re-indexed.

    Returns ((K, 3) float64 positions, (M, 3) int64 faces); -0.0 and 0.0 count as one position.
    """
    as_written = np.ascontiguousarray(np.asarray(vertices, dtype=np.float32) + np.float32(0.0))
    keys = as_written.view(np.dtype((np.void, as_written.dtype.itemsize * 3))).ravel()
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    return as_written[first].astype(np.float64), inverse.ravel()[np.asarray(faces, dtype=np.int64)]


def check_as_written(mesh: Mesh, min_area_mm2: float = MIN_FACE_AREA_MM2) -> SolidCheck:
    """The mesh as an STL reader sees it: float32 positions merged exactly (see merge_float32).

    Closed and consistently wound (every edge in exactly two faces, once in each direction), no
    face of `min_area_mm2` or less (a face with two corners at one position counts), positive volume.
    """
    vertices, faces = merge_float32(mesh.vertices, mesh.faces)
    collapsed = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
    # Faces with two corners at one position are counted as slivers, and left out of the edge count.
    return _check(vertices, faces[~collapsed], min_area_mm2, collapsed=int(collapsed.sum()))
