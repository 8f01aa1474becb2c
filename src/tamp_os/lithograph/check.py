"""`tamp-os check`: the legibility report of an image (as it would be printed) or of a mesh that
already exists (its top surface sampled on a grid), in plain sentences."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..export.meshfile import MESH_SUFFIXES, read_mesh_file  # noqa: F401  (MESH_SUFFIXES: the check command's test)
from ..relief.legibility import Legibility, assess



def heights_from_mesh(vertices: np.ndarray, faces: np.ndarray, pitch_mm: float = 0.25) -> np.ndarray:
    """The top surface of a relief-like solid as a height grid.

    Parameters
    ----------
    vertices : (n, 3) float positions in mm; faces : (m, 3) int.
    pitch_mm : grid spacing of the result.

    Returns
    -------
    (rows, cols) float64 heights in mm, row 0 = far edge (largest y); cells outside the top are 0.
    """
    from scipy.interpolate import LinearNDInterpolator

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    up = f[normals[:, 2] > 0.2 * np.linalg.norm(normals, axis=1)]  # faces that look up
    top = v[np.unique(up)]
    if len(top) < 3:
        raise InputError("the mesh has no upward-facing surface to measure.")
    (x0, y0), (x1, y1) = top[:, :2].min(axis=0), top[:, :2].max(axis=0)
    xs = np.arange(x0 + pitch_mm / 2, x1, pitch_mm)
    ys = np.arange(y1 - pitch_mm / 2, y0, -pitch_mm)
    gx, gy = np.meshgrid(xs, ys)
    # Where several top vertices share x, y (a wall's upper edge), the highest one is the surface.
    order = np.lexsort((-top[:, 2], top[:, 1], top[:, 0]))
    top = top[order]
    keep = np.ones(len(top), bool)
    keep[1:] = np.any(top[1:, :2] != top[:-1, :2], axis=1)
    surface = LinearNDInterpolator(top[keep, :2], top[keep, 2], fill_value=0.0)
    return surface(gx, gy)


def check_mesh(path: Path, *, nozzle_mm: float, layer_mm: float) -> Legibility:
    """Legibility of an existing mesh file (any format trimesh reads)."""
    mesh = read_mesh_file(path)
    pitch = 0.25
    heights = heights_from_mesh(mesh.vertices, mesh.faces, pitch)
    return assess(heights, pitch, nozzle_mm=nozzle_mm, layer_mm=layer_mm)
