"""Olympus OIB/OIF (FluoView) through oiffile. Not tested on a real file (no small public sample
exists); oiffile exposes the whole series, so the decoded-size guard prices all of it first."""

from __future__ import annotations

import numpy as np

from .model import Stack

KIND = "oif"


def open_oif(path, scene: int | None, limits) -> Stack:
    import oiffile

    from ..model import check_bytes
    from .plan import check_index

    oif = oiffile.OifFile(str(path))
    try:
        axes, shape, dtype = oif.axes, tuple(int(n) for n in oif.shape), np.dtype(oif.dtype)
        check_index(path, "scene", scene, count=1, what="image")
        if "Y" not in axes or "X" not in axes or any(a not in "TCZYX" for a in axes):
            raise NotImplementedError(f"axes {axes}")
        check_bytes(path, shape, dtype, limits=limits, what="Olympus OIB/OIF series")
        data = oif.asarray()
    finally:
        oif.close()
    sizes = {a: shape[axes.index(a)] for a in "TCZ" if a in axes}

    def plane(t: int, c: int, z: int) -> np.ndarray:
        where = {"T": t, "C": c, "Z": z}
        return data[tuple(where.get(a, slice(None)) for a in axes)]

    return Stack(format="Olympus OIB/OIF", reader=f"oiffile {oiffile.__version__}", sizes=sizes, dtype=dtype,
                 height=shape[axes.index("Y")], width=shape[axes.index("X")], plane=plane)
