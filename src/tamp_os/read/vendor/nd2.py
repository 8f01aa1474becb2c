"""Nikon ND2 through the `nd2` package (the maintained ND2 reader; reads one frame at a time).

Frames hold every channel of one point of the experiment loops (P positions, T, Z); a frame is
found from the file's loop indices and read alone (`read_frame`), so a long series is never
decoded whole. Pixel size from `voxel_size()` (µm); the z step from the ZStackLoop via the same.
"""

from __future__ import annotations

import numpy as np

from .model import Channel, Stack

KIND = "nd2"


def open_nd2(path, scene: int | None) -> Stack:
    import nd2

    from .plan import check_index

    f = nd2.ND2File(str(path))
    try:
        sizes_all = dict(f.sizes)
        extra = [a for a in sizes_all if a not in ("P", "T", "Z", "C", "Y", "X", "S")]
        if extra:
            raise NotImplementedError(f"loops {', '.join(extra)}")
        scenes = int(sizes_all.get("P", 1))
        s = check_index(path, "scene", scene, count=scenes, what="position")
        loops = [dict(ix) for ix in f.loop_indices]
        voxel = f.voxel_size()
        channels = []
        for c in f.metadata.channels or []:
            ch = c.channel
            channels.append(Channel(ch.name, ch.excitationLambdaNm or None, ch.emissionLambdaNm or None))
        dtype = np.dtype(f.dtype)
        calibrated = bool(f.metadata.channels) and f.metadata.channels[0].volume.axesCalibrated[0]
    except Exception:
        f.close()
        raise
    sizes = {a: int(sizes_all.get(a, 1)) for a in "TCZ"}
    c_axis = list(a for a in sizes_all if a not in ("P", "T", "Z")).index("C") if "C" in sizes_all else None

    def plane(t: int, c: int, z: int) -> np.ndarray:
        want = {k: v for k, v in (("P", s), ("T", t), ("Z", z)) if k in sizes_all}
        seq = next(i for i, ix in enumerate(loops) if all(ix.get(k, 0) == v for k, v in want.items()))
        frame = np.asarray(f.read_frame(seq))
        return np.take(frame, c, axis=c_axis) if c_axis is not None else frame

    return Stack(
        format="Nikon ND2", reader=f"nd2 {nd2.__version__}", sizes=sizes, dtype=dtype, height=int(sizes_all["Y"]),
        width=int(sizes_all["X"]), plane=plane, scenes=scenes, scene=s, channels=channels,
        pixel_size_m=(voxel.x * 1e-6, voxel.y * 1e-6) if calibrated else None,
        pixel_size_key="voxel_size() x, y (µm)" if calibrated else "",
        z_step_m=voxel.z * 1e-6 if sizes["Z"] > 1 else None, z_key="voxel_size() z (µm; ZStackLoop step)",
        samples=int(sizes_all.get("S", 1)), close=f.close,
    )
