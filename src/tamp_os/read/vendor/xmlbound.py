"""A bound on a vendor file's metadata XML, checked before its reader parses it (issue 40.4).

czifile and liffile parse the whole XML as they open a file, and liffile then walks nested
elements recursively: XML nested 200,000 deep failed half way as "maximum recursion depth
exceeded", reported as damaged image data. The XML is read here from the file's own header (CZI:
the metadata segment the file header points to; LIF: the UTF-16 block after the first 13 bytes)
and refused, in words, when it is larger than metadata can be or nested deeper than MAX_XML_DEPTH.
Anything this cannot read is left to the reader, which says what is wrong.
"""

from __future__ import annotations

import functools
import struct
from pathlib import Path

from ...errors import InputError
from ..xmltext import MAX_XML_CHARS, MAX_XML_DEPTH, xml_depth_over
from .errors import KINDS


def _czi_xml(fh) -> bytes | None:
    fh.seek(92)  # ZISRAWFILE: 32-byte segment header, then version, GUIDs, part, directory position
    (where,) = struct.unpack("<q", fh.read(8))
    fh.seek(where)
    head = fh.read(40)
    if len(head) < 40 or not head.startswith(b"ZISRAWMETADATA"):
        return None
    (size,) = struct.unpack("<i", head[32:36])
    if size > MAX_XML_CHARS:
        return b"too large"
    fh.seek(where + 32 + 256)
    return fh.read(max(size, 0))


def _lif_xml(fh) -> str | None:
    id0, _, id1, chars = struct.unpack("<IIBI", fh.read(13))
    if id0 != 0x70 or id1 != 0x2A:
        return None
    if chars > MAX_XML_CHARS:
        return "too large"
    return fh.read(chars * 2).decode("utf-16-le", errors="replace")


def check_metadata_xml(path: Path, kind: str) -> None:
    """InputError when the metadata XML of a CZI or LIF file is larger than metadata can be or nested
    deeper than MAX_XML_DEPTH; nothing for other kinds or for files this cannot read. A conversion
    opens a file up to three times (picture, channel route, channels): the verdict is kept per
    file version, so its XML is walked once (0.7 s for 200,000 elements)."""
    if kind not in ("czi", "lif"):
        return
    try:
        stat = Path(path).stat()
    except OSError:
        return
    problem = _problem(str(path), kind, stat.st_mtime_ns, stat.st_size)
    if problem:
        raise InputError(problem)


@functools.lru_cache(maxsize=16)
def _problem(path: str, kind: str, mtime_ns: int, size: int) -> str | None:
    read = {"czi": _czi_xml, "lif": _lif_xml}[kind]
    try:
        with open(path, "rb") as fh:
            text = read(fh)
    except (OSError, struct.error, ValueError):
        return None
    if text is None:
        return None
    what, todo = KINDS[kind]
    if text in ("too large", b"too large"):
        return f"{path}: {what} whose metadata XML is over {MAX_XML_CHARS:,} characters, larger than metadata can be; {todo}."
    if xml_depth_over(text):
        return (f"{path}: {what} whose metadata XML nests elements more than {MAX_XML_DEPTH} deep (a microscope's "
                f"metadata nests about a dozen); {todo}.")
    return None
