"""Core benchmark: image -> STL + 3MF + GLB on the FePt fixture at Medium (256 px) and High
(512 px), full-grid mesh, against the per-pixel loop baseline measured in the same run; and a
4096 × 4096 heightmap to STL (time and peak memory, in a child process). Prints a Markdown table.

    .venv/bin/python benchmarks/bench_core.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import reference_loop  # noqa: E402

from tamp_os.export import save_mesh  # noqa: E402
from tamp_os.lithograph.outputs import metadata, write_meshes  # noqa: E402
from tamp_os.lithograph.pipeline import make_lithograph  # noqa: E402

FEPT = Path(__file__).resolve().parents[1] / ".." / "shared" / "fixtures" / "fept_spheres_sem.png"


def timed(fn):
    start = time.perf_counter()
    value = fn()
    return value, time.perf_counter() - start


def ours(cols, out: Path, mesher="grid", clean=False, style="reference"):
    """Our pipeline as a user runs it: make_lithograph, then the three formats written together.

    clean=False does the loop's work only; clean=True adds annotation removal (the default).
    style="reference" is the loop's algorithm (brightness = height); other styles add their work.
    """
    start = time.perf_counter()
    litho = make_lithograph(
        FEPT, resolution_px=cols, blur_px=1.2, mesher=mesher, keep_annotations=not clean, relief_style=style,
        scale_bar="off", orientation_corner="none",  # the loop makes neither
    )
    made = time.perf_counter()
    written = write_meshes(litho.mesh, out, f"ours_{cols}_{mesher}_{style}", formats=["stl", "3mf", "glb"], meta=metadata(litho))
    saved = time.perf_counter()
    t = litho.report.timings_s
    return {
        "prep": made - start - t["mesh"], "mesh": t["mesh"],
        **{fmt: seconds for fmt, (_, seconds) in written.items()},
        "wall": saved - start, "tris": litho.mesh.n_triangles,
        "sizes": {fmt: path.stat().st_size for fmt, (path, _) in written.items()},
    }


def baseline(cols, out: Path):
    h, t_prep = timed(lambda: reference_loop.heightmap(FEPT, cols))
    (verts, faces), t_mesh = timed(lambda: reference_loop.mesh(h))
    times, sizes = {}, {}
    for fmt, fn in (("stl", reference_loop.stl_bytes), ("3mf", reference_loop.threemf_bytes), ("glb", reference_loop.glb_bytes)):
        data, times[fmt] = timed(lambda: fn(verts, faces))
        sizes[fmt] = len(data)
    wall = t_prep + t_mesh + sum(times.values())
    return {"prep": t_prep, "mesh": t_mesh, **times, "wall": wall, "tris": len(faces), "sizes": sizes}


def big_stl_child() -> None:
    """Runs in a child so its peak RSS is its own: 4096² heightmap -> grid solid -> STL."""
    from tamp_os.mesh.solid import grid_solid

    rng = np.random.default_rng(0)
    heights = 1.0 + 3.0 * rng.random((4096, 4096))
    start = time.perf_counter()
    mesh = grid_solid(heights, 100.0, 100.0)
    with tempfile.TemporaryDirectory() as tmp:
        path = save_mesh(mesh, Path(tmp) / "big.stl")
        size = path.stat().st_size
    elapsed = time.perf_counter() - start
    # VmHWM, not ru_maxrss: ru_maxrss keeps the parent's peak across exec.
    with open("/proc/self/status") as fh:
        peak_mb = next(int(line.split()[1]) for line in fh if line.startswith("VmHWM:")) / 1024
    print(f"{elapsed:.2f} {peak_mb:.0f} {mesh.n_triangles} {size}")


def fmt_row(label, r):
    total = r["wall"]  # ours writes the three formats side by side, so wall < sum of stages
    return (
        f"| {label} | {r['tris']:,} | {r['prep']:.3f} | {r['mesh']:.3f} | {r['stl']:.3f} | {r['3mf']:.3f} | {r['glb']:.3f} | "
        f"{total:.2f} | {r['sizes']['stl'] / 1e6:.1f} / {r['sizes']['3mf'] / 1e6:.1f} / {r['sizes']['glb'] / 1e6:.1f} |",
        total,
    )


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--big-child":
        big_stl_child()
        return
    print("| run | triangles | read+prep s | mesh s | STL s | 3MF s | GLB s | wall s | MB STL / 3MF / GLB |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        ours(64, out)  # warm imports so they are not charged to the first row
        for label, cols in (("Medium", 256), ("High", 512)):
            base = baseline(cols, out)
            mine = ours(cols, out)
            row_b, total_b = fmt_row(f"{label} {cols} px, per-pixel loop", base)
            row_m, total_m = fmt_row(f"{label} {cols} px, tamp-os grid", mine)
            print(row_b)
            print(row_m)
            speed_mesh_stl = (base["mesh"] + base["stl"]) / (mine["mesh"] + mine["stl"])
            print(f"| {label}: speed-up mesh+STL {speed_mesh_stl:.0f}×, all three formats {total_b / total_m:.0f}× | | | | | | | | |")
            styled = ours(cols, out, style="structure")
            print(fmt_row(f"{label} {cols} px, tamp-os grid, structure style", styled)[0])
    child = subprocess.run([sys.executable, __file__, "--big-child"], capture_output=True, text=True, check=True)
    seconds, peak_mb, tris, size = child.stdout.split()
    print()
    print("| 4096 × 4096 heightmap → STL | time s | peak RSS MB | triangles | STL MB |")
    print("|---|---:|---:|---:|---:|")
    print(f"| grid solid + binary STL | {float(seconds):.2f} | {peak_mb} | {int(tris):,} | {int(size) / 1e6:.0f} |")


if __name__ == "__main__":
    main()
