"""Which vendor format a file is, from its first bytes (a folder for OME-Zarr); no heavy imports."""

from __future__ import annotations

from pathlib import Path

HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
OLE2_MAGIC = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"
HEAD_BYTES = 1024


def kind_of_folder(path: Path) -> str | None:
    from .omezarr import is_ome_zarr

    return "omezarr" if is_ome_zarr(path) else None


def kind_of_head(head: bytes, path: Path) -> str | None:
    """The vendor kind the signature names, or None for files read.py handles (TIFF, DM, Pillow)."""
    suffix = path.suffix.lower()
    if head.startswith(b"ZISRAWFILE"):
        return "czi"
    if head[:4] == b"\x70\x00\x00\x00" and len(head) > 8 and head[8] == 0x2A:
        return "lif"
    if head[:4] == b"\xda\xce\xbe\x0a":
        return "nd2"
    if head.startswith(HDF5_MAGIC):
        return "hdf5"
    if head[:4] == b"II\x97\x01" or (head[:2] == b"JK" and suffix == ".emi"):
        return "tia"
    if head[208:212] == b"MAP ":
        return "mrc"
    if b"JED-" in head[:32]:
        return "jeol"
    if head.startswith(b"BZh") and (suffix == ".elid" or _bz2_starts_with(path, b"EID2")):
        return "elid"
    if (head.startswith(OLE2_MAGIC) and suffix == ".oib") or suffix == ".oif":
        return "oif"
    return None


def _bz2_starts_with(path: Path, magic: bytes) -> bool:
    import bz2

    decomp = bz2.BZ2Decompressor()
    try:
        with path.open("rb") as fh:
            while not decomp.eof:
                chunk = fh.read(1 << 16)
                if not chunk:
                    return False
                out = decomp.decompress(chunk, len(magic))
                if out:
                    return out.startswith(magic)
    except (OSError, ValueError):
        return False
    return False


def hdf5_kind(path: Path) -> str:
    """'hspy' for HyperSpy files, 'emd' for Velox/Berkeley EMD, 'hdf5' when it cannot be opened to tell."""
    try:
        import h5py

        with h5py.File(path, "r") as h5:
            fmt = h5.attrs.get("file_format", b"")
            fmt = fmt.decode() if isinstance(fmt, bytes) else str(fmt)
            if fmt.lower() in ("hyperspy", "hspy") or "Experiments" in h5:
                return "hspy"
            return "emd"
    except ImportError:
        return {".hspy": "hspy", ".emd": "emd"}.get(path.suffix.lower(), "emd")
    except Exception:  # not even its superblock reads: name it by its suffix
        return {".hspy": "hspy", ".emd": "emd"}.get(path.suffix.lower(), "hdf5")
