"""TEM and SEM formats that RosettaSciIO reads: FEI/Thermo Fisher TIA (.emi/.ser), Velox and
Berkeley EMD, JEOL Analysis Station (.img/.map), Phenom ELID and HyperSpy .hspy.

Why RosettaSciIO: it is the field's reference reader for these formats (HyperSpy's I/O), already
installed for DM3/DM4 (the `dm` extra), and opens all of them lazily except Phenom ELID (a small
bzip2 project file, read by rosettasciio's reader with its reads bounded and priced: read_elid). Only images are used:
items whose two axes are x and y; spectra, line scans and maps with an energy axis are skipped.
A further axis (frames of a series) is offered as time points.
"""

from __future__ import annotations

import functools
import logging
import os

import numpy as np

from ...errors import InputError, Text
from ...units import unit_factor_m
from ..cost import READER_BYTES
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
INPUT_BYTES = 1 << 16  # compressed bytes fed to the decompressor at a time
# rosettasciio reads a project value by value (a spectrum channel is one read of one to five bytes),
# and keeps most as Python objects: each read is priced at READ_BYTES of memory (a list of int32
# values: a pointer and an int object each; a map's values go into uint32 arrays, 4 bytes), held
# against `max_memory_gb`, and the reads are counted, MAX_READS at most (about 30 s of its reading
# at 1 µs a value: a 128×96 EDS map of 2048 channels holds 25 million; the real project of tests/ 1.7).
READ_BYTES = 40
MAX_READS = 30_000_000
LARGE_READ_BYTES = 1 << 16  # a record read whole (an embedded TIFF, a string): its bytes and their join are held
BZ2_STATE_BYTES = 3.7e6  # the decompressor's own tables for 900 kB blocks (bzip2's manual: 100 kB + 4 × block size)


TIFF_HEADS = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")  # classic and BigTIFF, either byte order


class ElidRefused(Exception):
    """Raised inside the bounded reader; open_rsciio turns it into one InputError line."""


def read_elid(path, limits) -> list:
    """rosettasciio's ELID reader, made to read only what the project declares, in bounded pieces,
    priced as it goes: a record (an embedded TIFF) declaring more than the cap is refused before a
    byte of it is decompressed, each embedded TIFF is priced from its header before tifffile decodes
    it (records and pixels against `max_decoded_gb`), and past what the values read would hold in
    memory (`max_memory_gb`) or MAX_READS values the reading stops. A bzip2 bomb whose header declares
    no image costs the 20 bytes its header takes; bytes past the declared layout are never decompressed
    (nor a second stream appended after the first, which rosettasciio never reads either)."""
    reader = bounded_reader_class()
    try:
        return reader(str(path), limits.max_decoded_gb * 1e9, limits.max_memory_gb * 1e9).dictionaries
    except ElidRefused as refused:
        raise _elid_refusal(path, limits, *refused.args) from None


def _elid_refusal(path, limits, kind: str, at: int, facts) -> InputError:
    from .errors import KINDS

    what, todo = KINDS["elid"]
    cap = f"the limit of {limits.max_decoded_gb:g} GB that guards against decompression bombs"
    memory = f"the limit of {limits.max_memory_gb:g} GB on the memory a conversion may use"
    if kind == "record":
        size, name = facts
        over = cap if name == "max_decoded_gb" else memory
        return InputError(
            f"{path}: {what} whose layout declares a record of {size:,} bytes at byte {at:,} of the project (the file is "
            f"{os.path.getsize(path):,} bytes); reading it would hold {2 * size / 1e9:.2g} GB, above {over}; {todo}.",
            hint=f"If you trust the file and the computer has the memory, raise the limit, for example `{name}` "
                 f"{max(1, int(2 * size / 1e9) + 1)}.")
    if kind == "reads":
        return InputError(
            f"{path}: {what} that holds more than {MAX_READS:,} values (spectra, maps, read one by one: that would take "
            f"more than a minute), so it is not read; {todo}.")
    if kind == "held":
        return InputError(
            f"{path}: {what} whose values read by byte {at:,} of the project already hold {facts / 1e9:.2g} GB, above {memory}; "
            f"{todo}.", hint="The limit is `max_memory_gb`; raise it only for a file you trust.")
    cost, (width, height) = facts
    return InputError(
        f"{path}: {what} whose embedded image at byte {at:,} of the project (a {width}×{height} TIFF) would decode to "
        f"{cost.total / 1e9:.1f} GB ({cost.words()}), above {cap}. The file is malformed or hostile; {todo}.",
        hint="The limit is `max_decoded_gb`; raise it only for a file you trust.")


@functools.cache
def bounded_reader_class():
    """rsciio.phenom's ElidReader with its one way in (`_read`) bounded, and its TIFFs priced."""
    from rsciio.phenom._api import ElidReader

    return type("BoundedElidReader", (BoundedReads, ElidReader), {})


class BoundedReads:
    """The bounds of the ELID reader (mixed into rosettasciio's ElidReader by bounded_reader_class):
    its one way in, `_read`, counts and prices every read, decompresses in bounded pieces and
    refuses (ElidRefused) past the cap; each embedded TIFF is priced before tifffile decodes it."""

    def __init__(self, pathname, cap_bytes: float, memory_bytes: float | None = None):
        self._cap = cap_bytes  # decoded data: the records read whole, an embedded TIFF's pixels
        self._memory = cap_bytes if memory_bytes is None else memory_bytes  # all that the read holds
        self._large, self._reads, self._at, self._tiff_reads = 0.0, 0, 0, None
        self._reads_allowed = self._values_allowed()
        self.tiff_costs: list = []  # (byte of the project, Cost, (width, height)) of each TIFF read
        super().__init__(pathname)

    def _values_allowed(self) -> float:
        """How many values may be read: MAX_READS, or fewer when what they would hold passes the memory limit."""
        return min(MAX_READS, (self._memory - BZ2_STATE_BYTES - READER_BYTES - self._large) / READ_BYTES)

    @property
    def held_bytes(self) -> float:
        """The memory priced so far: the decompressor and the reader's own objects, READ_BYTES a value,
        and each large record twice."""
        return BZ2_STATE_BYTES + READER_BYTES + self._reads * READ_BYTES + self._large

    def _read(self, size=1):
        # the hot path (1.7 million calls for a real project): one count, one C call, no more
        self._reads += 1
        if self._reads > self._reads_allowed or size >= LARGE_READ_BYTES or self._tiff_reads is not None:
            return self._read_priced(size)
        data = self._decompressor.decompress(b"", size)
        if len(data) < size:
            data = self._decompressed(size, data, tiff=False)
        self._at += len(data)
        return data

    def _read_priced(self, size: int) -> bytes:
        """A read past the count allowed, of a large record, or inside an embedded TIFF."""
        if self._reads > self._reads_allowed:
            raise ElidRefused("reads" if self._reads > MAX_READS else "held", self._at, self.held_bytes)
        if size >= LARGE_READ_BYTES:
            self._large += 2 * size  # the pieces and their join
            if self._large > self._cap or self.held_bytes > self._memory:  # before a byte of it is decompressed
                raise ElidRefused("record", self._at, (size, "max_decoded_gb" if self._large > self._cap else "max_memory_gb"))
            self._reads_allowed = self._values_allowed()
        data = self._decompressor.decompress(b"", min(size, PIECE_BYTES))
        if len(data) < size:
            data = self._decompressed(size, data, tiff=self._tiff_reads == 1)
        if self._tiff_reads is not None:
            self._tiff_reads += 1
            if self._tiff_reads == 2:  # the record's length, then the TIFF's bytes: priced before tifffile decodes them
                self._price_tiff(data)
        self._at += len(data)
        return data

    def _decompressed(self, size: int, first: bytes, *, tiff: bool) -> bytes:
        """`size` bytes of the stream, `first` of them already out, in pieces of at most PIECE_BYTES
        (fewer where the stream ends, as rosettasciio's own reader gives; a stream cut short is an
        error, not a wait for more). A TIFF's bytes must start as a TIFF: checked before the rest."""
        pieces, got, inflate = [first], len(first), self._decompressor
        while got < size and not inflate.eof:
            if tiff and got >= 4:
                head = b"".join(pieces)[:4]
                if head not in TIFF_HEADS:
                    raise ValueError(f"the embedded image at byte {self._at:,} of the project is no TIFF")
                tiff = False
            chunk = b""
            if inflate.needs_input:
                chunk = self._file.read(INPUT_BYTES)
                if not chunk:
                    raise EOFError("the compressed stream ends early")
            piece = inflate.decompress(chunk, min(size - got, PIECE_BYTES))
            pieces.append(piece)
            got += len(piece)
        return pieces[0] if len(pieces) == 1 else b"".join(pieces)

    def _read_tiff(self):
        self._tiff_reads = 0
        try:
            return super()._read_tiff()
        finally:
            self._tiff_reads = None

    def _price_tiff(self, data: bytes) -> None:
        found = tiff_cost(data)
        if found is not None:
            self.tiff_costs.append((self._at, *found))
            if found[0].total + self._large > self._cap:
                raise ElidRefused("tiff", self._at, found)



def tiff_cost(data: bytes):
    """(Cost, (width, height)) of the TIFF in `data`, priced from its header as read.py prices a TIFF
    file: pixels, the tiles (or strips) decoded at once, and the frame a JPEG tile declares; None when
    `data` is no TIFF (rosettasciio's tifffile then reports it)."""
    import io
    import math

    import tifffile

    from ..cost import Cost, tiff_chunk_bytes, tiff_jpeg_bytes

    buffer = io.BytesIO(data)
    try:
        with tifffile.TiffFile(buffer) as tif:
            cost, size = Cost(), None
            for page in tif.pages:
                shape = tuple(int(v) for v in page.shape)
                size = size or (int(page.imagewidth), int(page.imagelength))
                cost.add("pixels", math.prod(shape) * page.dtype.itemsize)
                cost.add("tiles being decoded", tiff_chunk_bytes(page))
                cost.add("JPEG frames", tiff_jpeg_bytes(buffer, page))
            return cost, size or (0, 0)
    except Exception:  # not a TIFF after all, or a damaged one: rosettasciio's tifffile says so
        log.debug("no TIFF priced in %d bytes", len(data))
        return None


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
        _reader(kind)  # rosettasciio's logger quietened
        items = read_elid(path, limits)
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
