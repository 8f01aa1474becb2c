"""Binary STL written as a numpy structured array, in chunks so memory stays bounded."""

from __future__ import annotations

import numpy as np

STL_RECORD = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
CHUNK = 1 << 20


def write_stl(mesh, fh, metadata: dict) -> None:
    title = metadata.get("title", "TAMP-OS lithograph")
    header = f"binary STL, millimetres: {title}".encode("ascii", "replace")[:80].ljust(80, b" ")
    fh.write(header)
    fh.write(np.uint32(mesh.n_triangles).tobytes())
    for start in range(0, mesh.n_triangles, CHUNK):
        faces = mesh.faces[start : start + CHUNK]
        records = np.zeros(len(faces), dtype=STL_RECORD)
        records["normal"] = mesh.face_normals(start, start + CHUNK)
        records["v"] = mesh.vertices[faces]
        fh.write(records.tobytes())
