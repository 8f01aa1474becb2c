"""3MF written directly: the model XML formatted from numpy arrays and zipped once, with unit
millimetre, metadata and (for several parts) base materials.

The package holds 3D/3dmodel.model, [Content_Types].xml, _rels/.rels (the one relationship, to
the model) and the slicers' attachments under Metadata/, which PrusaSlicer, Bambu Studio and
OrcaSlicer read by name and so carry no relationship (see write_3mf_parts). Numbers are written
the way lib3mf (the 3MF Consortium's library, which wrote these files before) writes them: six
decimals of the float32 coordinates, so every reader gets the same vertices. Formatting the
arrays a block of rows per NumPy operation (decimal_text.py: the characters '%.6f' and '%d' write)
and compressing once is several times faster than lib3mf writing a package and a second pass
dropping its attachment relationships. UUIDs are derived from
the content, and every entry has a fixed date, so the same input gives the same bytes.
"""

from __future__ import annotations

import hashlib
import io
import os
import uuid
import zipfile
from collections import deque
from collections.abc import Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .markup import xml_text

CORE_NS = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
PRODUCTION_NS = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
MODEL_PATH = "3D/3dmodel.model"
MODEL_RELATIONSHIP = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"
# zlib level 4: within 3 % of level 6's size on a relief's model XML, in 40 % of the time.
COMPRESS_LEVEL = 4
ZIP_DATE = (1980, 1, 1, 0, 0, 0)  # the earliest a zip can hold: no clock in the bytes
INDENT = "\t\t\t\t\t"


def _text(value) -> str:
    """`value` escaped for XML element text (xml.sax's escape would import urllib). A carriage
    return (and CR LF) becomes a newline, as an XML reader such as PrusaSlicer's expat reads it;
    lib3mf does not normalise line ends and refuses the character reference that would keep
    one, so only this way do all readers read the same text."""
    return xml_text(value).replace("\r\n", "\n").replace("\r", "\n").replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def _attr(value) -> str:
    """`value` escaped for a double-quoted XML attribute: as _text, and tab and newline become
    spaces, as an XML reader normalises an attribute (lib3mf does not: see _text)."""
    return _text(value).replace("\t", " ").replace("\n", " ")


def write_3mf(mesh, fh, metadata: dict) -> None:
    """`mesh` (mesh.solid.Mesh or any object with vertices (n, 3) mm and faces (m, 3)) as one 3MF
    mesh object in `fh`, with the metadata's title, description, designer and application and,
    when metadata["print_settings"] is given, the slicers' print settings."""
    vertices, faces = _arrays(mesh.vertices, mesh.faces)
    geometry = Geometry(vertices, faces, title=metadata.get("title", "TAMP-OS lithograph"), object_id=1)
    _write_package(fh, _model_xml(geometry, metadata), _print_settings(metadata))


class Geometry:
    """One mesh object's geometry as float32 / uint32 arrays, its XML id and name, and the UUID
    seed derived from its content (the same seed lib3mf's writer here used)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, *, title: str, object_id: int):
        self.vertices, self.faces, self.title, self.object_id = vertices, faces, title, object_id
        digest = hashlib.sha256(np.ascontiguousarray(vertices))  # then the faces: the hash of both joined, without joining them
        digest.update(np.ascontiguousarray(faces))
        self.seed = uuid.UUID(digest.hexdigest()[:32])

    def uuid(self, what: str) -> str:
        return str(uuid.uuid5(self.seed, what))


def _arrays(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    return np.ascontiguousarray(vertices, dtype=np.float32), np.ascontiguousarray(faces, dtype=np.uint32)


# Rows of vertices or triangles formatted and compressed at a time (about 0.5 MB of text): the
# model is never one string (a 2000 x 2000 grid's would be 0.6 GB) joined and encoded again.
CHUNK_ROWS = 1 << 13
# Triangle indices are copied from a table of each vertex index's digits (a gather, not divisions
# per corner) up to this many vertices; beyond, the table costs more memory than it saves.
INDEX_TABLE_MAX = 1 << 21
VERTEX_PARTS = [b'<vertex x="', b'" y="', b'" z="', b'"/>\n']


def _vertices_xml(vertices: np.ndarray) -> bytes:
    """<vertex> lines: six decimals of each float32 coordinate (lib3mf's precision), formatted by
    NumPy (decimal_text) or, for values it does not take (inf, nan, huge), by Python."""
    from . import decimal_text

    if not decimal_text.fixed_six_supported(vertices):
        return _vertices_xml_plain(vertices).encode("ascii")
    fields = decimal_text.fixed_six(vertices.ravel())
    width = fields.shape[1]
    fields = fields.reshape(len(vertices), 3 * width)
    return decimal_text.lines_text([fields[:, :width], fields[:, width : 2 * width], fields[:, 2 * width :]], VERTEX_PARTS)


def _vertices_xml_plain(vertices: np.ndarray) -> str:
    """<vertex> lines as Python's '%.6f' writes them, one format operation over the whole array."""
    return ('<vertex x="%.6f" y="%.6f" z="%.6f"/>\n' * len(vertices)) % tuple(vertices.astype(np.float64).ravel().tolist())


def _triangles_xml(faces: np.ndarray, material: str = "", *, table: np.ndarray | None = None) -> bytes:
    """<triangle> lines (0-based vertex indices, as '%d' writes them); `material` is extra
    attributes for all of them (pid and p1), empty for the object's default material; `table`:
    decimal_text.index_table covering every index, or None to compute the digits."""
    from . import decimal_text

    if len(faces) == 0:
        return b""
    fields = decimal_text.index_fields(faces.ravel(), table=table)
    fields = fields.reshape(len(faces), 3, fields.shape[1])
    parts = [b'<triangle v1="', b'" v2="', b'" v3="', f'"{material}/>\n'.encode("utf-8")]
    return decimal_text.lines_text([fields[:, 0], fields[:, 1], fields[:, 2]], parts)


def _index_table(n_vertices: int, faces: np.ndarray) -> np.ndarray | None:
    """decimal_text.index_table of the vertices when it covers every face's index and is small
    enough (INDEX_TABLE_MAX), else None (the digits are computed)."""
    from . import decimal_text

    if not len(faces) or n_vertices > INDEX_TABLE_MAX or int(faces.max()) >= n_vertices:
        return None
    return decimal_text.index_table(n_vertices)


def _model_xml(geometry: Geometry, metadata: dict, *, resources: str = "", object_extra: str = "",
               triangle_ranges: list[tuple[int, int, str]] | None = None) -> tuple[int, Iterator[bytes]]:
    """The 3D/3dmodel.model part: at most how many bytes long, and its bytes in pieces.
    Metadata, `resources` before the object (base materials), the object (with `object_extra`
    attributes) and one build item, all with content-derived UUIDs. `triangle_ranges`: (first,
    stop, extra attributes of those triangles), in order over all of them (default: one range, no attributes)."""
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<model xmlns="{CORE_NS}" xmlns:p="{PRODUCTION_NS}" unit="millimeter" xml:lang="en-US">',
    ]
    for key in ("Title", "Description", "Designer", "Application"):
        value = metadata.get(key.lower())
        if value:
            lines.append(f'<metadata name="{key}" type="string" preserve="1">{_text(value)}</metadata>')
    lines += ["<resources>", resources] if resources else ["<resources>"]
    lines.append(f'<object id="{geometry.object_id}" name="{_attr(geometry.title)}" type="model" p:UUID="{geometry.uuid("object")}"{object_extra}>')
    lines.append("<mesh>\n<vertices>\n")
    head = "\n".join(lines).encode("utf-8")
    tail = (
        "</triangles>\n</mesh>\n</object>\n</resources>\n"
        f'<build p:UUID="{geometry.uuid("build")}">\n'
        f'<item objectid="{geometry.object_id}" p:UUID="{geometry.uuid("item")}"/>\n</build>\n</model>\n'
    ).encode("utf-8")
    ranges = triangle_ranges or [(0, len(geometry.faces), "")]
    return len(head) + len(tail) + _body_bytes_max(geometry, ranges), _model_pieces(head, geometry, ranges, tail)


def _body_bytes_max(geometry: Geometry, ranges: list[tuple[int, int, str]]) -> int:
    """At most how long the <vertex> and <triangle> lines are: every number as wide as the widest."""
    v, n = geometry.vertices, len(geometry.vertices)
    widest = float(np.abs(v).max()) if n else 0.0
    if not np.isfinite(widest):
        return zipfile.ZIP64_LIMIT  # 'inf' or 'nan' in the text: measured exactly instead (see _write_package)
    number = 1 + len(str(int(widest) + 1)) + 7  # sign, digits, point, six decimals
    index = len(str(n))
    triangles = sum((stop - first) * (len('<triangle v1="" v2="" v3=""/>\n') + len(extra) + 3 * index) for first, stop, extra in ranges)
    return n * (len('<vertex x="" y="" z=""/>\n') + 3 * number) + len("</vertices>\n<triangles>\n") + triangles


def _model_pieces(head: bytes, geometry: Geometry, ranges: list[tuple[int, int, str]], tail: bytes) -> Iterator[bytes]:
    """The model's bytes: `head`, the vertices and the triangles CHUNK_ROWS at a time, `tail`."""
    yield head
    vertices, faces = geometry.vertices, geometry.faces
    for start in range(0, len(vertices), CHUNK_ROWS):
        yield _vertices_xml(vertices[start : start + CHUNK_ROWS])
    yield b"</vertices>\n<triangles>\n"
    table = _index_table(len(vertices), faces)
    for first, stop, extra in ranges:
        for start in range(first, stop, CHUNK_ROWS):
            yield _triangles_xml(faces[start : min(start + CHUNK_ROWS, stop)], extra, table=table)
    yield tail


SLIC3R_MODEL_CONFIG = "Metadata/Slic3r_PE_model.config"
# The three .config parts are text (PrusaSlicer's model config XML, its print config lines, Bambu's JSON);
# OPC gives a content type per extension, so one that is true of all three.
CONFIG_CONTENT_TYPE = "text/plain"
# Contains "PrusaSlicer" (what Bambu Studio and OrcaSlicer look for) without starting with
# "PrusaSlicer-", which PrusaSlicer would read as the version of the PrusaSlicer that wrote it.
PRUSA_LAYOUT = "volumes in PrusaSlicer 3MF layout"


def write_3mf_parts(parts, fh, metadata: dict) -> None:
    """Several single-colour parts (tactile.parts.Part) as ONE object with one volume per part.

    The parts' triangles go into one mesh object, part after part (each part keeps its own
    vertices, so each stays a closed solid on its own). Two descriptions of the split ride along:
    every triangle names its part's base material (3MF core, read by any 3MF reader: name and
    display colour), and the attachment Metadata/Slic3r_PE_model.config (PrusaSlicer's own
    convention) cuts the object into volumes by triangle ranges and gives part k extruder k + 1.
    PrusaSlicer then loads one object with one part per colour; a components object instead
    falls apart into separate objects there.

    Bambu Studio and OrcaSlicer (not installable here, so read from their source, not run) load
    a 3MF with their own importer, which ignores this attachment and makes one part of a mesh
    object, unless the package looks like PrusaSlicer's: then they hand it to their copy of
    PrusaSlicer's importer, which reads the volumes. Their test (Model::read_from_archive,
    check_3mf_from_prusa) is: no 3D/_rels/3dmodel.model.rels in the package, and an Application
    metadata whose text contains "PrusaSlicer". So the attachment is stored without a
    relationship (as PrusaSlicer stores it) and the Application says whose layout this is.
    """
    offsets = np.cumsum([0] + [len(p.mesh.vertices) for p in parts])
    vertices, faces = _arrays(
        np.concatenate([p.mesh.vertices for p in parts]), np.concatenate([np.asarray(p.mesh.faces, dtype=np.int64) + off for p, off in zip(parts, offsets)])
    )
    face_counts = [len(p.mesh.faces) for p in parts]
    title = xml_text(metadata.get("title", "TAMP-OS lithograph"))
    geometry = Geometry(vertices, faces, title=title, object_id=2)  # the base materials are resource 1
    bases = "".join(f'<base name="{_attr(p.label)}" displaycolor="#{"%02X%02X%02X" % tuple(p.colour_rgb)}FF"/>\n' for p in parts)
    # Part k's triangles name base material k; the object's default (k = 0) needs no attributes (3MF core).
    starts = np.cumsum([0] + face_counts)
    ranges = [(int(a), int(b), f' pid="1" p1="{k}"' if k else "") for k, (a, b) in enumerate(zip(starts, starts[1:]))]
    application = f"{metadata.get('application', 'TAMP-OS')} ({PRUSA_LAYOUT})"
    model = _model_xml(
        geometry,
        {**metadata, "application": application},
        resources=f'<basematerials id="1">\n{bases}</basematerials>',
        object_extra=' pid="1" pindex="0"',
        triangle_ranges=ranges,
    )
    config = slic3r_model_config(geometry.object_id, title, [p.label for p in parts], face_counts=face_counts)
    _write_package(fh, model, [(SLIC3R_MODEL_CONFIG, config)] + _print_settings(metadata))


def _print_settings(metadata: dict) -> list[tuple[str, bytes]]:
    """The print settings (metadata["print_settings"], an export.print_settings.PrintSettings) as
    PrusaSlicer's Metadata/Slic3r_PE.config and Bambu Studio / OrcaSlicer's Metadata/project_settings.config.
    Both slicers find them by name, so like the model config they go in without a relationship: a
    relationship from the model would make Bambu Studio and OrcaSlicer look for model parts in them."""
    from ..printing.print_settings import BAMBU_PROJECT_SETTINGS, PRUSA_CONFIG

    settings = metadata.get("print_settings")
    if settings is None:
        return []
    return [(PRUSA_CONFIG.lstrip("/"), settings.prusa_config()), (BAMBU_PROJECT_SETTINGS.lstrip("/"), settings.bambu_project_settings())]


def slic3r_model_config(object_id: int, name: str, part_names: list[str], *, face_counts: list[int]) -> bytes:
    """PrusaSlicer's Metadata/Slic3r_PE_model.config for one object split into volumes.

    Volume k covers triangles sum(face_counts[:k]) .. sum(face_counts[:k + 1]) - 1 (inclusive)
    of object `object_id` (its id in the 3MF model), is a model part named part_names[k], and
    prints with extruder k + 1. PrusaSlicer refuses the whole file when a metadata element's
    type is neither "object" nor "volume", so every one carries it.
    """
    from xml.etree import ElementTree as ET

    root = ET.Element("config")
    obj = ET.SubElement(root, "object", id=str(object_id), instances_count="1")
    ET.SubElement(obj, "metadata", type="object", key="name", value=name)
    first = 0
    for k, (part_name, count) in enumerate(zip(part_names, face_counts)):
        volume = ET.SubElement(obj, "volume", firstid=str(first), lastid=str(first + count - 1))
        for key, value in (("name", xml_text(part_name)), ("volume_type", "ModelPart"), ("extruder", str(k + 1))):
            ET.SubElement(volume, "metadata", type="volume", key=key, value=value)
        first += count
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8", xml_declaration=False) + b"\n"


def _content_types(attachments: bool) -> bytes:
    """[Content_Types].xml: every part's extension has a content type (OPC)."""
    types = [("rels", "application/vnd.openxmlformats-package.relationships+xml"), ("model", "application/vnd.ms-package.3dmanufacturing-3dmodel+xml")]
    types += [("config", CONFIG_CONTENT_TYPE)] if attachments else []
    lines = "".join(f'<Default Extension="{ext}" ContentType="{kind}"/>\n' for ext, kind in types)
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">\n{lines}</Types>\n').encode()


def _root_relationships() -> bytes:
    """_rels/.rels: the package's one relationship, to the model (the attachments are found by name)."""
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">\n'
        f'<Relationship Type="{MODEL_RELATIONSHIP}" Target="/{MODEL_PATH}" Id="rel0"/>\n</Relationships>\n'
    ).encode()


def _write_package(fh, model: tuple[int, Iterable[bytes]], attachments: list[tuple[str, bytes]]) -> None:
    """The zip package into `fh`, in one pass (built in memory, so a failure writes nothing).
    `model`: at most how long the model is, and its bytes in pieces. zlib's output does not
    depend on how its input is cut, so the entry holds what compressing the model whole gives."""
    entries = [*attachments, ("[Content_Types].xml", _content_types(bool(attachments))), ("_rels/.rels", _root_relationships())]
    size_max, pieces = model
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED, compresslevel=COMPRESS_LEVEL) as archive:
        if size_max * 1.05 <= zipfile.ZIP64_LIMIT:  # writestr would not take Zip64 either: the same entry
            # By name: the archive's method and level, and ZipInfo's default date (ZIP_DATE).
            with archive.open(MODEL_PATH, "w") as dest:
                write_in_order(dest.write, pieces, threaded=os.environ.get("TAMP_THREADS") != "1")
        else:  # writestr decides on Zip64 from the exact size
            entries.insert(0, (MODEL_PATH, b"".join(pieces)))
        for name, data in entries:
            info = zipfile.ZipInfo(name, date_time=ZIP_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(info, data, compresslevel=COMPRESS_LEVEL)
    fh.write(buffer.getbuffer())


# Pieces formatted ahead of the one being compressed: enough to keep zlib busy, few enough that
# memory stays a few pieces.
PIPELINE_DEPTH = 2


def write_in_order(write, pieces: Iterable[bytes], *, threaded: bool = True) -> None:
    """write(piece) for every piece, in order. `threaded`: on one helper thread while the next
    pieces are made in this one (zlib and NumPy's formatting release the GIL, so the model's
    compression runs beside its formatting); the calls and their order are the same, so are the
    bytes. An error on either side stops both and reaches the caller once the helper is idle."""
    if not threaded:
        for piece in pieces:
            write(piece)
        return
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="tamp-3mf") as helper:
        pending: deque = deque()
        try:
            for piece in pieces:
                pending.append(helper.submit(write, piece))
                while len(pending) > PIPELINE_DEPTH or (pending and pending[0].done()):
                    pending.popleft().result()
            while pending:
                pending.popleft().result()
        except BaseException:
            for waiting in pending:  # not begun: never begun; the one running ends before the with does
                waiting.cancel()
            raise

