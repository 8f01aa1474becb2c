"""MRC/CCP4 maps through mrcfile (the CCP-EM reference library), memory-mapped.

The header says which file axis is X, Y and Z (mapc, mapr, maps: columns, rows, sections); the
volume is viewed in X, Y, Z order whatever the file's order, so the print shows the X–Y plane and
Z is the stack. The voxel size is the cell length over the sampling (cella / mx, my, mz), not
over the number of columns, rows and sections (they differ for maps cut from a larger cell).
Y points up in MRC viewers (ChimeraX, IMOD), so rows are flipped once to match them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...errors import Decision, InputError
from .model import Channel, Stack

KIND = "mrc"
ANGSTROM_M = 1e-10
HEADER_BYTES = 1024
MODE_BYTES = {0: 1, 1: 2, 2: 4, 3: 4, 4: 8, 6: 2, 12: 2, 101: 0.5}  # MRC2014 modes (101: 4-bit, two voxels a byte)


def check_header(path, limits) -> None:
    """Refuse, from the 1024-byte header alone, a map whose extended header (nsymbt) and declared
    voxels (nx × ny × nz × bytes of its mode) need more bytes than the file holds, or more than the
    decoded-bytes cap: mrcfile would otherwise allocate or map them before finding out."""
    import struct

    from ..cost import check_declared
    from .errors import KINDS

    size = Path(path).stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(HEADER_BYTES)
    if len(head) < HEADER_BYTES:
        return  # mrcfile reports the short header as damage
    stamp = ">" if head[212:213] == b"\x11" else "<"  # machine stamp 0x11 0x11: big-endian
    for order in (stamp, "<" if stamp == ">" else ">"):  # a wrong stamp: the other order, as mrcfile guesses
        nx, ny, nz, mode = struct.unpack(order + "4i", head[:16])
        nsymbt = struct.unpack(order + "i", head[92:96])[0]
        if mode in MODE_BYTES and min(nx, ny, nz) >= 0:
            break
    else:
        return  # neither byte order gives a known mode: mrcfile names the problem
    what, todo = KINDS[KIND]
    cap = limits.max_decoded_gb if limits is not None else float("inf")
    if nsymbt < 0:
        raise InputError(f"{path}: {what} whose header declares an extended header of {nsymbt} bytes (negative): the file is "
                         f"damaged or hostile; {todo}.")
    check_declared(path, what, f"an extended header of {nsymbt:,} bytes", declared_bytes=float(nsymbt), file_bytes=size - HEADER_BYTES, max_decoded_gb=cap, todo=todo,
                   holds=f"the {size - HEADER_BYTES:,} bytes after its 1024-byte header hold")
    voxels = float(math.ceil(nx / 2) if mode == 101 else nx * MODE_BYTES[mode]) * ny * nz  # 4-bit rows end on a byte
    check_declared(path, what, f"{nx}×{ny}×{nz} voxels of {MODE_BYTES[mode]:g} bytes (mode {mode})", declared_bytes=voxels,
                   file_bytes=size - HEADER_BYTES - nsymbt, max_decoded_gb=cap, todo=todo, capped=False,  # memory-mapped: the planes read are priced
                   holds=f"the {size - HEADER_BYTES - nsymbt:,} bytes after its headers hold")


def open_mrc(path, scene: int | None, limits=None) -> Stack:
    import mrcfile

    from .plan import check_index

    check_header(path, limits)
    mrc = mrcfile.mmap(str(path), mode="r")  # strict: a truncated file is refused, not padded
    try:
        h = mrc.header
        data = mrc.data
        if data is None or data.ndim not in (2, 3):
            raise ValueError("no 2-D or 3-D data")
        if data.ndim == 2:
            data = data[np.newaxis]
        order = (int(h.mapc), int(h.mapr), int(h.maps))  # file axis (column, row, section) -> 1=X, 2=Y, 3=Z
        if sorted(order) != [1, 2, 3]:
            raise ValueError(f"axis order mapc, mapr, maps = {order} is not a permutation of 1, 2, 3")
        data_axis = {order[0]: 2, order[1]: 1, order[2]: 0}  # physical axis -> numpy axis (sections, rows, cols)
        volume = np.transpose(data, (data_axis[3], data_axis[2], data_axis[1]))  # (Z, Y, X), still a memory map
        check_index(path, "scene", scene, count=1, what="volume")
        voxel = mrc.voxel_size  # cella / (mx, my, mz), in Å
        vx, vy, vz = (float(voxel.x), float(voxel.y), float(voxel.z))
        dtype = volume.dtype
    except Exception:
        mrc.close()
        raise
    notes = []
    if order != (1, 2, 3):
        notes.append(Decision(f"MRC axis order (mapc, mapr, maps) = {order}: the volume was reordered to X, Y, Z."))
    angles = tuple(float(a) for a in (h.cellb.alpha, h.cellb.beta, h.cellb.gamma))
    if any(abs(a - 90) > 0.01 for a in angles if a):
        notes.append(f"the unit cell is not orthogonal (angles {', '.join(f'{a:g}' for a in angles)}°); the print shows the voxel grid unskewed.")
    meta = {"mrc_axis_order": list(order), "mrc_space_group": int(h.ispg), "mrc_cell_A": [float(c) for c in (h.cella.x, h.cella.y, h.cella.z)],
            "mrc_sampling": [int(h.mx), int(h.my), int(h.mz)], "mrc_start": [int(h.nxstart), int(h.nystart), int(h.nzstart)],
            "mrc_nversion": int(h.nversion)}

    def plane(t: int, c: int, z: int) -> np.ndarray:
        return np.array(volume[z, ::-1, :])

    nz = volume.shape[0]
    return Stack(
        format="MRC/CCP4 map", reader=f"mrcfile {mrcfile.__version__}", sizes={"Z": nz}, dtype=dtype,
        height=volume.shape[1], width=volume.shape[2], plane=plane, channels=[Channel("density")],
        pixel_size_m=(vx * ANGSTROM_M, vy * ANGSTROM_M) if vx > 0 and vy > 0 else None,
        pixel_size_key="header cella / (mx, my) in Å", z_step_m=vz * ANGSTROM_M if vz > 0 and nz > 1 else None,
        z_key="header cella.z / mz in Å", metadata=meta, notes=notes, close=mrc.close,
    )
