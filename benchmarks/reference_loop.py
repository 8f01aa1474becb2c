"""A straightforward per-pixel / per-triangle loop implementation of the reference algorithm,
written here as the speed baseline: the same stages as the reference notebooks (grayscale,
contrast stretch, blur, invert, heights, top + full-grid bottom + walls, then STL, 3MF and GLB
built element by element in Python). Used only by the benchmarks."""

from __future__ import annotations

import io
import json
import math
import struct
import zipfile

import numpy as np
from PIL import Image
from scipy import ndimage


def heightmap(path, cols, blur_px=1.2, base_mm=1.0, relief_mm=3.0):
    im = Image.open(path).convert("L")
    rows = round(cols * im.height / im.width)
    arr = np.asarray(im.resize((cols, rows), Image.LANCZOS), dtype=np.float64)
    lo, hi = np.percentile(arr, [2, 98])
    arr = np.clip((arr - lo) / (hi - lo), 0, 1)
    arr = ndimage.gaussian_filter(arr, blur_px)
    return base_mm + relief_mm * arr


def mesh(h, width_mm=100.0):
    rows, cols = h.shape
    pitch = width_mm / (cols - 1)
    verts, faces = [], []
    for r in range(rows):
        for c in range(cols):
            verts.append((c * pitch, (rows - 1 - r) * pitch, float(h[r, c])))
    for r in range(rows):
        for c in range(cols):
            verts.append((c * pitch, (rows - 1 - r) * pitch, 0.0))
    n = rows * cols
    for r in range(rows - 1):
        for c in range(cols - 1):
            a, b, d, e = r * cols + c, r * cols + c + 1, (r + 1) * cols + c, (r + 1) * cols + c + 1
            faces += [(d, e, b), (d, b, a), (n + d, n + b, n + e), (n + d, n + a, n + b)]
    def wall(i, j):
        faces.extend([(j, i, n + i), (j, n + i, n + j)])
    for c in range(cols - 1):
        wall((rows - 1) * cols + c, (rows - 1) * cols + c + 1)
        wall(c + 1, c)
    for r in range(rows - 1):
        wall((r + 1) * cols + cols - 1, r * cols + cols - 1)
        wall(r * cols, (r + 1) * cols)
    return verts, faces


def stl_bytes(verts, faces):
    out = [b"\0" * 80, struct.pack("<I", len(faces))]
    for f in faces:
        p = [verts[i] for i in f]
        u = [p[1][k] - p[0][k] for k in range(3)]
        v = [p[2][k] - p[0][k] for k in range(3)]
        nx, ny, nz = u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]
        length = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
        out.append(struct.pack("<12fH", nx / length, ny / length, nz / length, *p[0], *p[1], *p[2], 0))
    return b"".join(out)


def threemf_bytes(verts, faces):
    parts = ['<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"><resources><object id="1" type="model"><mesh><vertices>']
    for x, y, z in verts:
        parts.append(f'<vertex x="{x:.4f}" y="{y:.4f}" z="{z:.4f}"/>')
    parts.append("</vertices><triangles>")
    for a, b, c in faces:
        parts.append(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>')
    parts.append('</triangles></mesh></object></resources><build><item objectid="1"/></build></model>')
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("3D/3dmodel.model", "".join(parts))
    return buf.getvalue()


def glb_bytes(verts, faces):
    vb = b"".join(struct.pack("<3f", *v) for v in verts)
    ib = b"".join(struct.pack("<3I", *f) for f in faces)
    doc = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": len(vb) + len(ib)}],
           "bufferViews": [{"buffer": 0, "byteLength": len(vb)}, {"buffer": 0, "byteOffset": len(vb), "byteLength": len(ib)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(verts), "type": "VEC3"},
                         {"bufferView": 1, "componentType": 5125, "count": 3 * len(faces), "type": "SCALAR"}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]}
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    body = vb + ib
    return b"glTF" + struct.pack("<II", 2, 28 + len(js) + len(body)) + struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(body), b"BIN\0") + body
