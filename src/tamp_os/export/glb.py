"""Binary glTF 2.0 through trimesh: indexed, with vertex normals (computed by Mesh, which is
much faster than trimesh's own). Coordinates are millimetres like every other export."""

from __future__ import annotations


def write_glb(mesh, fh, metadata: dict) -> None:
    import trimesh
    from trimesh.exchange.gltf import export_glb

    tm = trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces, vertex_normals=mesh.vertex_normals(), process=False)
    fh.write(export_glb(trimesh.Scene(tm), include_normals=True))
