"""Slivers left by boolean operations, removed as a slicer would otherwise meet them.

manifold3d works in double precision; written as float32 (STL, 3MF, GLB), two of its vertices a
few nanometres apart become one position, and on a large flat wall it leaves triangles whose third
corner lies on their longest edge. `remove_slivers` welds the positions as written, drops the
faces that collapse, and flips the longest edge of each remaining zero-area triangle with its
neighbour (on a flat wall that changes nothing a finger or a nozzle can feel).
"""

from __future__ import annotations

import numpy as np

from .solid import INDEX, Mesh
from .validate import MIN_FACE_AREA_MM2, check_as_written, merge_float32


def _areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    tri = vertices[faces]
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def as_written(mesh: Mesh) -> Mesh:
    """`mesh` as a slicer will read it: unchanged when it is sound written as float32, else with its
    faces of no area removed (a boolean's cut through a fine relief, a volume's bare model)."""
    return mesh if check_as_written(mesh).ok else remove_slivers(mesh)


def remove_slivers(mesh: Mesh, passes: int = 6) -> Mesh:
    """`mesh` welded as written (float32 positions) without faces of no area; see the module's notes."""
    vertices, faces = merge_float32(mesh.vertices, mesh.faces)
    faces = np.asarray(faces, dtype=np.int64)
    collapsed = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
    faces = faces[~collapsed]
    for _ in range(passes):
        bad = np.flatnonzero(_areas(vertices, faces) <= MIN_FACE_AREA_MM2)
        if bad.size == 0:
            break
        owner = {}
        for i, (a, b, c) in enumerate(faces.tolist()):
            owner[(a, b)] = i
            owner[(b, c)] = i
            owner[(c, a)] = i
        touched: set[int] = set()
        for i in bad.tolist():
            if i in touched:
                continue
            tri = faces[i]
            p = vertices[tri]
            k = int(np.argmax([np.linalg.norm(p[(j + 1) % 3] - p[j]) for j in range(3)]))  # the longest edge: k -> k+1
            a, b, c = int(tri[k]), int(tri[(k + 1) % 3]), int(tri[(k + 2) % 3])
            j = owner.get((b, a))
            if j is None or j in touched:
                continue
            other = faces[j]
            d = int(next(v for v in other.tolist() if v not in (a, b)))
            faces[i] = (c, a, d)
            faces[j] = (c, d, b)
            touched.update((i, j))
    return Mesh(vertices, faces.astype(INDEX))


PINCH_NUDGE_MM = 1e-3  # far under a layer; far over float32's step at 1000 mm (61 nm)


def part_pinches(mesh: Mesh, *, nudge_mm: float = PINCH_NUDGE_MM) -> Mesh:
    """`mesh` with the copies of each pinch parted: a solid that touches itself along an edge or at
    a point holds several vertices at one position (manifold3d keeps them apart by index), which a
    reader merging by position (every slicer) sees as one, with an edge of four faces. Each copy
    moves `nudge_mm` toward the middle of its own faces, into its own sheet of the surface."""
    _, inverse, counts = np.unique(mesh.vertices.astype(np.float32), axis=0, return_inverse=True, return_counts=True)
    shared = counts[inverse.ravel()] > 1
    if not shared.any():
        return mesh
    faces = np.asarray(mesh.faces, dtype=np.int64)
    centres = np.repeat(mesh.vertices[faces].mean(axis=1), 3, axis=0)
    middle = np.zeros_like(mesh.vertices)
    np.add.at(middle, faces.ravel(), centres)
    middle /= np.maximum(np.bincount(faces.ravel(), minlength=len(mesh.vertices)), 1)[:, None]
    toward = middle[shared] - mesh.vertices[shared]
    length = np.linalg.norm(toward, axis=1, keepdims=True)
    vertices = mesh.vertices.astype(np.float64, copy=True)
    vertices[shared] += toward / np.where(length == 0, 1.0, length) * nudge_mm
    return Mesh(vertices, mesh.faces)
