"""Checks a vendor file passes from its headers before any library opens its data (issue 40).

The web app reads files from anyone who can reach it, so each reader must stay inside the input
and price what it will decode before decoding it:

- HDF5 (Velox/Berkeley EMD, HyperSpy .hspy): the whole link tree is walked with h5py without
  following a single link (`Group.visititems_links` is HDF5's H5Lvisit: it lists each link with
  its type and recurses only into hard-linked groups, once each). An external link, a link of a
  user-defined (unknown) type, a dataset with external storage (`dataset.external`) or a virtual
  dataset (`dataset.is_virtual`) anywhere in the file is refused: each makes HDF5 read another
  file, and HDF5 opens it when the data is read, whoever reads it (rosettasciio included).
  Soft links are allowed and not followed: a soft link holds a path inside the same file, and it
  can only lead out through an external link, which the walk finds and refuses wherever it sits.
  Every dataset's chunk is priced against `max_decoded_gb`: a decoder allocates a whole chunk
  (and holds the compressed chunk beside it: HDF5_CHUNK_COPIES), and a 64×64 dataset may declare
  one chunk of 60000×60000; a chunk far larger than its dataset is refused whatever the cap. Datasets other than the payloads
  (named Data/data: rosettasciio opens the images lazily and plan.py prices the planes read) are
  priced whole: rosettasciio reads metadata arrays eagerly, and a dataset never written costs no
  bytes in the file however large it is declared (h5py returns its fill value).
- OME-Zarr folders: every entry is listed without following symlinks; a symlink (file or folder)
  whose target resolves outside the folder, or an array path that resolves outside it, is refused.
  Symlinks that stay inside the folder are allowed (they read nothing the folder does not hold).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from ...errors import InputError
from ..cost import HDF5_CHUNK_COPIES, check_chunk, check_chunk_fits, check_declared, chunk_bytes, chunk_past_data
from .errors import KINDS

PAYLOADS = ("Data", "data")  # the image (and spectrum) arrays of Velox and HyperSpy files
MAX_HDF5_LINKS = 200_000  # a Velox file holds a few hundred; more is a file built to make the walk slow
MAX_FOLDER_ENTRIES = 2_000_000  # files and folders of an OME-Zarr store (a large pyramid holds ~10⁵ chunks)


def outside(path, kind: str, where: str, *, folder: bool = False) -> InputError:
    """'x.emd: an EMD file whose link Data/Image/x/Data (...) refers to data outside this file; ... Export it as one file: ...'."""
    what, todo = KINDS[kind]
    whole = "folder" if folder else "file"
    return InputError(f"{path}: {what} whose {where} refers to data outside this {whole}; it is not read (a {whole} given to "
                      f"this program may only use its own bytes). Export it as one {whole}: {todo}.")


def check_hdf5(path, kind: str, limits) -> None:
    """Refuse an HDF5 file that refers to data outside itself, or whose chunks decode above the cap."""
    import h5py

    found: list = []
    count = [0]
    with h5py.File(path, "r") as h5:
        def visit(name, link):
            count[0] += 1
            if count[0] > MAX_HDF5_LINKS:
                found.append(("many", name, None))
                return True  # stop the walk
            if isinstance(link, h5py.ExternalLink):
                found.append(("outside", f"link {name} (an external link to {link.filename}:{link.path})", None))
                return True
            if isinstance(link, h5py.SoftLink):
                return None  # inside this file by construction; not followed
            if not isinstance(link, h5py.HardLink):
                found.append(("outside", f"link {name} (a link of a user-defined type)", None))
                return True
            obj = h5.get(name)
            if isinstance(obj, h5py.Dataset):
                if obj.is_virtual:
                    found.append(("outside", f"dataset {name} (a virtual dataset)", None))
                    return True
                if obj.external:
                    found.append(("outside", f"dataset {name} (stored in external files)", None))
                    return True
                declared = math.prod(float(n) for n in obj.shape or ()) * obj.dtype.itemsize
                if name.rsplit("/", 1)[-1] not in PAYLOADS and declared > limits.max_decoded_gb * 1e9:
                    found.append(("declared", name, (obj.shape, obj.dtype.itemsize, declared)))
                    return True
                if obj.chunks:
                    chunk = chunk_bytes(obj.shape, obj.chunks, obj.dtype.itemsize, copies=HDF5_CHUNK_COPIES)
                    if chunk > limits.max_decoded_gb * 1e9 or chunk_past_data(obj.shape, obj.chunks, obj.dtype.itemsize):
                        found.append(("chunk", name, (obj.shape, obj.chunks, obj.dtype.itemsize, chunk)))
                        return True
            return None

        h5.visititems_links(visit)
    for what, name, facts in found:
        label = KINDS[kind][0]
        if what == "outside":
            raise outside(path, kind, name)
        if what == "many":
            raise InputError(f"{path}: {label} with more than {MAX_HDF5_LINKS:,} objects; a microscope file holds a few "
                             f"hundred, so it is not read. {KINDS[kind][1][:1].upper()}{KINDS[kind][1][1:]}.")
        if what == "declared":
            shape, itemsize, declared = facts
            dims = "×".join(str(int(n)) for n in shape)
            check_declared(path, label, f"a dataset {name} of {dims} values of {itemsize} byte{'s' if itemsize != 1 else ''}", declared_bytes=declared, file_bytes=math.inf,
                           max_decoded_gb=limits.max_decoded_gb, todo=KINDS[kind][1])
        shape, chunks, itemsize, chunk = facts
        where = f"{label} whose dataset {name}"
        check_chunk_fits(path, where, shape, chunks=chunks, itemsize=itemsize, todo=KINDS[kind][1])
        check_chunk(path, where, shape, chunks=chunks, itemsize=itemsize, n_bytes=chunk, max_decoded_gb=limits.max_decoded_gb,
                    todo=KINDS[kind][1])


def check_array_paths(path: Path, kind: str, array_paths) -> None:
    """Refuse a store whose metadata names an array outside its folder ('../other.zarr/0')."""
    root = Path(path).resolve()
    for rel in array_paths:
        if Path(str(rel)).is_absolute() or not _inside(root, (root / str(rel)).resolve()):
            raise outside(path, kind, f"array path {str(rel)!r}", folder=True)


def check_folder(path: Path, kind: str) -> None:
    """Refuse a folder (an OME-Zarr store) with a symlink that leads out of it."""
    root = Path(path).resolve()
    seen = 0
    stack = [root]
    while stack:
        folder = stack.pop()
        try:
            entries = list(os.scandir(folder))
        except OSError:
            continue  # unreadable: the reader reports it
        for entry in entries:
            seen += 1
            if seen > MAX_FOLDER_ENTRIES:
                raise InputError(f"{path}: {KINDS[kind][0]} with more than {MAX_FOLDER_ENTRIES:,} files; it is not read. "
                                 f"Write it again with larger chunks, or export OME-TIFF.")
            if entry.is_symlink():
                target = Path(entry.path).resolve()
                if not _inside(root, target):
                    rel = Path(entry.path).relative_to(root).as_posix()
                    raise outside(path, kind, f"entry {rel} (a symbolic link to {target})", folder=True)
                continue  # a link inside the folder: its target is listed where it lives
            if entry.is_dir(follow_symlinks=False):
                stack.append(Path(entry.path))


def _inside(root: Path, target: Path) -> bool:
    return target == root or root in target.parents
