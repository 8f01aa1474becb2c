"""Adaptive vs full-grid meshes: triangles, STL/3MF size, mesh time at Low/Medium/High on the
FePt and Zeiss fixtures (max error 0.06 mm); the default pipeline (adaptive) image -> STL + 3MF +
GLB against the per-pixel loop at 256 and 512 px; PrusaSlicer time for both meshes when installed.

    .venv/bin/python benchmarks/bench_adaptive.py
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from bench_core import FEPT, baseline, ours  # noqa: E402

from tamp_os.export import save_mesh  # noqa: E402
from tamp_os.lithograph.pipeline import make_lithograph  # noqa: E402

ZEISS = FEPT.parent / "test_tiff_Zeiss_SEM_1k.tif"


def slice_seconds(mesh_path: Path, out: Path) -> str:
    exe = shutil.which("prusa-slicer")
    if not exe:
        return "n/a"
    start = time.perf_counter()
    done = subprocess.run(
        [exe, "--export-gcode", "--layer-height", "0.12", "--nozzle-diameter", "0.4", "--fill-density", "15%",
         "--fill-pattern", "gyroid", "--output", str(out), str(mesh_path)],
        capture_output=True, text=True, timeout=900,
    )
    return f"{time.perf_counter() - start:.1f}" if done.returncode == 0 else "failed"


def main() -> None:
    slicing = "--slice" in sys.argv
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        print("| image | preset | grid | mesher | triangles | mesh s | STL MB | 3MF MB | ratio |" + (" slice s |" if slicing else ""))
        print("|---|---|---|---|---:|---:|---:|---:|---:|" + ("---:|" if slicing else ""))
        for image in (FEPT, ZEISS):
            for preset in ("low", "medium", "high"):
                rows = {}
                for mesher in ("grid", "adaptive"):
                    litho = make_lithograph(image, preset=preset, mesher=mesher, max_error_mm=0.06, scale_bar="off")
                    stl = save_mesh(litho.mesh, out / f"{mesher}.stl")
                    tmf = save_mesh(litho.mesh, out / f"{mesher}.3mf")
                    rows[mesher] = (litho, stl.stat().st_size, tmf.stat().st_size,
                                    slice_seconds(stl, out / f"{mesher}.gcode") if slicing else None)
                ratio = rows["grid"][0].mesh.n_triangles / rows["adaptive"][0].mesh.n_triangles
                for mesher, (litho, stl_b, tmf_b, sliced) in rows.items():
                    g = litho.report["grid"]
                    print(f"| {image.name} | {preset} | {g[0]}×{g[1]} | {mesher} | {litho.mesh.n_triangles:,} | "
                          f"{litho.report['timings_s']['mesh']:.3f} | {stl_b / 1e6:.2f} | {tmf_b / 1e6:.2f} | "
                          f"{'%.0f×' % ratio if mesher == 'adaptive' else ''} |" + (f" {sliced} |" if slicing else ""))
        print()
        print("| FePt, image → STL + 3MF + GLB | triangles | wall s | speed-up vs loop |")
        print("|---|---:|---:|---:|")
        ours(64, out, mesher="adaptive")  # warm imports
        for cols in (256, 512):
            # Best of three runs each: this shared 2-core machine is noisy at the 10 ms scale.
            base = min((baseline(cols, out) for _ in range(3)), key=lambda r: r["wall"])
            same = min((ours(cols, out, mesher="adaptive") for _ in range(3)), key=lambda r: r["wall"])
            full = min((ours(cols, out, mesher="adaptive", clean=True) for _ in range(3)), key=lambda r: r["wall"])
            print(f"| {cols} px, per-pixel loop | {base['tris']:,} | {base['wall']:.2f} | 1× |")
            print(f"| {cols} px, tamp-os adaptive, the loop's work | {same['tris']:,} | {same['wall']:.3f} | {base['wall'] / same['wall']:.0f}× |")
            print(f"| {cols} px, tamp-os default (adaptive + annotation removal) | {full['tris']:,} | {full['wall']:.3f} | {base['wall'] / full['wall']:.0f}× |")


if __name__ == "__main__":
    main()
