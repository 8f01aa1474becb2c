"""TEM and SEM formats that RosettaSciIO reads: FEI/Thermo Fisher TIA (.emi/.ser), Velox and
Berkeley EMD, JEOL Analysis Station (.img/.map), Phenom ELID and HyperSpy .hspy.

Why RosettaSciIO: it is the field's reference reader for these formats (HyperSpy's I/O), already
installed for DM3/DM4 (the `dm` extra), and opens all of them lazily except Phenom ELID (a small
bzip2 project file whose decompressed size is counted before it is decoded). Only images are used:
items whose two axes are x and y; spectra, line scans and maps with an energy axis are skipped.
A further axis (frames of a series) is offered as time points.
"""

from __future__ import annotations

import bz2
import logging
import os

import numpy as np

from ...errors import InputError, Text
from ...units import unit_factor_m
from .model import Channel, Stack

log = logging.getLogger(__name__)


def _reader(kind: str):
    import rsciio  # noqa: F401  (configures its logger first)

    logging.getLogger("rsciio").setLevel(logging.ERROR)  # its "numba is not installed" notice is not the user's concern
    if kind == "tia":
        from rsciio.tia import file_reader
    elif kind == "emd":
        from rsciio.emd import file_reader
    elif kind == "jeol":
        from rsciio.jeol import file_reader
    elif kind == "elid":
        from rsciio.phenom import file_reader
    else:
        from rsciio.hspy import file_reader
    return file_reader


PIECE_BYTES = 1 << 20  # decompressed at most this much at a time: memory stays flat whatever the stream's ratio


def elid_decoded_bytes(path, cap_bytes: float) -> int:
    """Bytes the ELID's bzip2 stream holds once decompressed, counted in pieces of at most
    PIECE_BYTES (a bzip2 stream expands up to ~45 million times: 64 kB in may be GBs out), stopping
    as soon as the count passes `cap_bytes`. Nothing decompressed is kept."""
    return sum(len(piece) for piece in elid_pieces(path, cap_bytes))


def elid_pieces(path, cap_bytes: float):
    """The decompressed pieces (each at most PIECE_BYTES) of the ELID's first bzip2 stream, the one
    rosettasciio reads (a second stream appended after it is never read by either), until past `cap_bytes`."""
    total, decomp = 0, bz2.BZ2Decompressor()
    with open(path, "rb") as fh:
        while not decomp.eof and total <= cap_bytes:
            if decomp.needs_input:
                chunk = fh.read(1 << 16)
                if not chunk:
                    raise EOFError("the compressed stream ends early")
            else:
                chunk = b""  # the decompressor still holds input: drain it, one bounded piece at a time
            piece = decomp.decompress(chunk, max_length=PIECE_BYTES)
            total += len(piece)
            yield piece


def check_elid(path, limits) -> None:
    """Refuse an ELID project whose bzip2 stream decompresses to more than `max_decoded_gb`
    (rosettasciio decompresses it whole); counted in bounded pieces, stopping past the cap."""
    import math

    from .errors import KINDS

    cap = limits.max_decoded_gb * 1e9
    size = elid_decoded_bytes(path, cap)
    what, todo = KINDS["elid"]
    if size > cap:
        raise InputError(
            f"{path}: {what} whose bzip2 stream decompresses to more than {size / 1e9:.2g} GB (counting stopped there; "
            f"the file is {os.path.getsize(path):,} bytes), above the limit of {limits.max_decoded_gb:g} GB that guards "
            f"against decompression bombs; {todo}.",
            hint=f"If you trust the file and the computer has the memory, raise the limit, for example `max_decoded_gb` "
                 f"{max(1, math.ceil(size / 1e9) * 2)}.")
    for at, cost, (width, height) in elid_tiff_costs(path, cap):
        if cost.total > cap:
            raise InputError(
                f"{path}: {what} whose embedded image at byte {at:,} of the project (a {width}×{height} TIFF) would decode to "
                f"{cost.total / 1e9:.1f} GB ({cost.words()}), above the limit of {limits.max_decoded_gb:g} GB that guards against "
                f"decompression bombs. The file is malformed or hostile; {todo}.",
                hint="The limit is `max_decoded_gb`; raise it only for a file you trust.")


TIFF_HEADS = (b"II*\x00", b"MM\x00*")


MAX_TIFFS_TRIED = 10_000  # a project holds tens of images; spectra hold a TIFF signature by chance about once in 4 GB


def elid_tiff_costs(path, cap_bytes: float = float("inf")):
    """(offset, Cost, (width, height)) of every TIFF embedded in an ELID project, priced from its
    header as read.py prices a TIFF file: pixels, the tiles (or strips) decoded at once, and the
    frame a JPEG tile declares. rosettasciio stores each as a uint32 length and the TIFF's bytes,
    and decodes it with tifffile (zlib/deflate or JPEG tiles included); every TIFF signature in the
    decompressed stream is tried, so none escapes. Call after elid_decoded_bytes has found the
    stream within `cap_bytes`: it is decompressed here in memory (at most that)."""
    import io
    import math

    import tifffile

    from ..cost import Cost, tiff_chunk_bytes, tiff_jpeg_bytes

    raw = b"".join(elid_pieces(path, cap_bytes))
    data = memoryview(raw)
    out, tried = [], 0
    for head in TIFF_HEADS:
        at = raw.find(head)
        while at >= 4:
            n = int.from_bytes(raw[at - 4:at], "little")
            tried += 1
            if tried > MAX_TIFFS_TRIED:
                raise ValueError(f"more than {MAX_TIFFS_TRIED:,} TIFF signatures in the project")
            if n >= 8:  # rosettasciio reads n bytes, or what is left when the stream ends first
                buffer = io.BytesIO(data[at:at + n])
                try:
                    with tifffile.TiffFile(buffer) as tif:
                        cost, size = Cost(), None
                        for page in tif.pages:
                            shape = tuple(int(v) for v in page.shape)
                            size = size or (int(page.imagewidth), int(page.imagelength))
                            cost.add("pixels", math.prod(shape) * page.dtype.itemsize)
                            cost.add("tiles being decoded", tiff_chunk_bytes(page))
                            cost.add("JPEG frames", tiff_jpeg_bytes(buffer, page))
                        out.append((at, cost, size or (0, 0)))
                except Exception:  # not a TIFF after all (bytes of a spectrum), or a damaged one rosettasciio reports
                    log.debug("%s: no TIFF at byte %d of the project", path, at)
            at = raw.find(head, at + 1)
    return out


def check_jeol(path, limits) -> None:
    """Refuse a JEOL .img whose Image/Size declares more pixels than its Image/Bits hold, or than the cap:
    rosettasciio resizes the stored bits to the declared size, allocating it whole (zeros past the data)."""
    from ..cost import check_declared
    from .errors import KINDS

    found = jeol_image_fields(path)
    what, todo = KINDS["jeol"]
    if found.get("many"):
        raise InputError(f"{path}: {what} with more than {MAX_JEOL_FIELDS:,} header fields (a real file has a few hundred); "
                         f"the file is damaged or hostile; {todo}.")
    if not found or not found.get("Size"):
        return  # not the layout priced here (or a size rosettasciio cannot resize to): it reads or refuses it
    width, height = found["Size"]
    itemsize, stored = found.get("Bits", (1, 0))
    declared = float(width) * float(height) * itemsize
    words = f"an image of {width}×{height} pixels"
    check_declared(path, what, words, declared_bytes=declared, file_bytes=stored, max_decoded_gb=limits.max_decoded_gb, todo=todo,
                   holds=f"the {stored:,} bytes of pixels it stores (Image/Bits)")


JEOL_TYPES = {1: 1, 2: 2, 3: 4, 4: 4, 5: 8, 6: 1, 7: 2, 8: 4, 9: 4, 10: 8, 11: 1, 12: 1, 13: 1, 14: 2, 20: 1}  # bytes (rsciio's jTYPE)
JEOL_NUMBERS = {1: "B", 2: "H", 3: "i", 4: "f", 5: "d", 6: "B", 7: "H", 8: "i", 9: "f", 10: "d", 14: "H"}
MAX_JEOL_FIELDS = 100_000


def jeol_image_fields(path) -> dict:
    """{'Size': (width, height), 'Bits': (bytes per value, bytes stored)} of a JEOL .img's Image
    group, found by walking its tagged tree as rosettasciio does, but skipping over every value
    (never reading one larger than 16 bytes), so a hostile header costs no memory."""
    import struct

    size = os.path.getsize(path)
    out: dict = {}
    with open(path, "rb") as fh:
        head = fh.read(48)
        if len(head) < 48 or struct.unpack("<I", head[:4])[0] != 52:
            return out
        data_pos = struct.unpack("<I", head[44:48])[0]
        fh.seek(data_pos + 12)
        keys: list[str] = []
        for _ in range(MAX_JEOL_FIELDS):
            mark = fh.read(1)
            if not mark:
                break
            mark = struct.unpack("b", mark)[0]
            if mark == 1:
                raw = fh.read(4)
                if len(raw) < 4:
                    break
                n = struct.unpack("<i", raw)[0]
                if n < 0:
                    break  # rosettasciio reads the rest of the file as the name, and finds no image
                key = fh.read(n).rstrip(b"\x00")
                key = (key[:-1] if key[-1:] == b"\xde" else key).decode("latin-1")  # rsciio drops a trailing 0xDE
                kinds = fh.read(8)
                if len(kinds) < 8:
                    break
                val_type, val_len = struct.unpack("<2i", kinds)
                keys.append(key)  # every field is closed by a -1 mark, a value as a group
                if val_type == 0:
                    continue
                if val_len < 0 or fh.tell() + val_len > size:
                    val_len = max(0, size - fh.tell())  # numpy reads what is there
                if keys == ["Image", "Size"] and val_type in JEOL_NUMBERS and val_len <= 64:
                    item = JEOL_TYPES[val_type]
                    values = struct.unpack(f"<{val_len // item}{JEOL_NUMBERS[val_type]}", fh.read(val_len // item * item))
                    fh.seek(val_len % item, 1)
                    if len(values) == 2 and all(float(v).is_integer() for v in values):  # what rsciio resizes to
                        out["Size"] = tuple(int(v) for v in values)
                elif keys == ["Image", "Bits"]:
                    out["Bits"] = (JEOL_TYPES.get(val_type, 1), val_len)
                    fh.seek(val_len, 1)
                else:
                    fh.seek(val_len, 1)
            elif mark == -1:
                if keys:
                    keys.pop()
                else:
                    break
            else:
                break
        else:
            out["many"] = True
    return out


def _image_axes(item) -> tuple[int, int] | None:
    """Indices of the (y, x) axes of an image item, or None for spectra, line scans and maps."""
    axes = item.get("axes", [])
    names = [str(a.get("name", "")).lower() for a in axes]
    others = [a for i, a in enumerate(axes) if names[i] not in ("x", "y")]
    if any("ev" in str(a.get("units", "")).lower() or "energy" in str(a.get("name", "")).lower() for a in others):
        return None  # a spectrum image (EDS/EELS map), not a picture
    if "x" in names and "y" in names:
        return names.index("y"), names.index("x")
    return None


def open_rsciio(path, kind: str, scene: int | None, *, limits) -> Stack:
    from .plan import check_index

    if kind in ("emd", "hspy"):
        from .bounds import check_hdf5

        check_hdf5(path, kind, limits)  # before rosettasciio opens it: nothing outside the file, chunks priced
    if kind == "jeol":
        check_jeol(path, limits)
    if kind == "elid":
        check_elid(path, limits)
        items = _reader(kind)(str(path))
    else:
        items = _reader(kind)(str(path), lazy=True)
    images = [(item, ax) for item in items for ax in [_image_axes(item)] if ax is not None and len(item["axes"]) <= 3]
    if not images:
        raise LookupError("no image in it (only spectra or maps)")
    s = check_index(path, "scene", scene, count=len(images), what="image")
    item, (yi, xi) = images[s]
    data = item["data"]
    rgba = data.dtype.names is not None
    frames = [i for i in range(len(item["axes"])) if i not in (yi, xi)]
    ax_x, ax_y = item["axes"][xi], item["axes"][yi]
    fx, fy = unit_factor_m(str(ax_x.get("units", ""))), unit_factor_m(str(ax_y.get("units", "")))
    px = float(ax_x.get("scale", 0)) * fx if fx else None
    py = float(ax_y.get("scale", 0)) * fy if fy else None
    title = str((item.get("metadata", {}).get("General", {}) or {}).get("title") or f"image {s}")
    titles = [str((it.get("metadata", {}).get("General", {}) or {}).get("title") or f"image {i}") for i, (it, _) in enumerate(images)]
    nt = int(data.shape[frames[0]]) if frames else 1
    dtype = np.dtype(np.uint8) if rgba else np.dtype(data.dtype)

    def plane(t: int, c: int, z: int) -> np.ndarray:
        index = [slice(None)] * data.ndim
        if frames:
            index[frames[0]] = t
        out = np.asarray(data[tuple(index)])
        if yi > xi:
            out = out.T
        if rgba:
            out = np.stack([out[name] for name in data.dtype.names], axis=-1)
        return out

    notes = []
    if len(images) > 1:
        notes.append(Text(f"{len(images)} images in the file ({'; '.join(f'{i}: {t}' for i, t in enumerate(titles))}); read {s} ({title}). Choose another with `scene`."))
    return Stack(
        format=FORMAT_NAMES[kind], reader=f"rosettasciio {_version()}", sizes={"T": nt}, dtype=dtype,
        height=int(data.shape[yi]), width=int(data.shape[xi]), plane=plane, scenes=len(images), scene=s,
        scene_name=title, channels=[Channel(title)], pixel_size_m=(px, py or px) if px and px > 0 else None,
        pixel_size_key=f"axes['{ax_x.get('name')}'].scale ({ax_x.get('units')})" if px else "",
        samples=len(data.dtype.names) if rgba else 1, metadata={"rsciio_title": title}, notes=notes,
    )


FORMAT_NAMES = {"tia": "FEI TIA (.emi/.ser)", "emd": "EMD (Velox/Berkeley)", "jeol": "JEOL Analysis Station",
                "elid": "Phenom ELID", "hspy": "HyperSpy .hspy"}


def _version() -> str:
    from importlib.metadata import version

    return version("rosettasciio")
