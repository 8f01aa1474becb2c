"""OBJ (text) and PLY (binary) through trimesh's writers."""

from __future__ import annotations


def _trimesh(mesh):
    import trimesh

    return trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces, process=False)


def write_obj(mesh, fh, metadata: dict) -> None:
    from trimesh.exchange.obj import export_obj

    fh.write(export_obj(_trimesh(mesh), include_normals=False, include_texture=False, header=None).encode())


def write_ply(mesh, fh, metadata: dict) -> None:
    from trimesh.exchange.ply import export_ply

    fh.write(export_ply(_trimesh(mesh), encoding="binary", include_attributes=False))
