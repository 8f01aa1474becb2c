"""Memory benchmark (issue 21): a 2 GB synthetic z-stack converts with peak memory under 1 GB.

Writes a 250 × 2000 × 2000 uint16 stack (2.0 GB decoded) as an OME-Zarr folder and as an OME-TIFF
(one page per slice), then converts each with `tamp-os convert` in a child process (default
settings: a maximum-intensity projection over Z); the child reports its own peak resident memory
(VmHWM in /proc/self/status), so each peak is that conversion's alone. Not ru_maxrss: Linux carries
the replaced address space's peak across exec, so a child's ru_maxrss starts at its parent's.

    PYTHONPATH=src .venv/bin/python benchmarks/bench_vendor_memory.py [SLICES]
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SIDE_PX = 2000
LIMIT_MB = 1000


def slice_of(z: int) -> np.ndarray:
    """A slice with structure that changes with z (a disc that grows), so the projection means something."""
    yy, xx = np.ogrid[:SIDE_PX, :SIDE_PX]
    r = 200 + 3 * z
    plane = ((xx - SIDE_PX / 2) ** 2 + (yy - SIDE_PX / 2) ** 2 < r * r).astype(np.uint16) * (1000 + z)
    plane[:: 97, :] += 50  # faint lines: not a trivially compressible stack
    return plane


def write_zarr(path: Path, slices: int) -> None:
    import zarr

    group = zarr.open_group(str(path), mode="w", zarr_format=2)
    array = group.create_array("0", shape=(slices, SIDE_PX, SIDE_PX), dtype=np.uint16, chunks=(1, 500, SIDE_PX))
    for z in range(slices):
        array[z] = slice_of(z)
    group.attrs["multiscales"] = [{"version": "0.4", "axes": [
        {"name": "z", "type": "space", "unit": "micrometer"}, {"name": "y", "type": "space", "unit": "micrometer"},
        {"name": "x", "type": "space", "unit": "micrometer"}],
        "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [0.5, 0.1, 0.1]}]}]}]


def write_ome_tiff(path: Path, slices: int) -> None:
    import tifffile

    def planes():
        for z in range(slices):
            yield slice_of(z)

    tifffile.imwrite(path, planes(), shape=(slices, SIDE_PX, SIDE_PX), dtype=np.uint16, ome=True,
                     metadata={"axes": "ZYX", "PhysicalSizeX": 0.1, "PhysicalSizeY": 0.1, "PhysicalSizeZ": 0.5})


def convert(path: Path, out: Path) -> tuple[float, float, str]:
    """(wall s, this child's peak RSS in MB, last line of its output)."""
    start = time.perf_counter()
    code = ("import sys; from tamp_os.cli.commands import main; rc = main(sys.argv[1:]); "
            "print('peak_kb', next(int(l.split()[1]) for l in open('/proc/self/status') if l.startswith('VmHWM:'))); "
            "sys.exit(rc)")
    done = subprocess.run([sys.executable, "-c", code, "convert", str(path), "-o", str(out)], capture_output=True, text=True,
                          env=os.environ.copy())
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{path.name}: conversion failed:\n{done.stdout}\n{done.stderr}")
    peak_kb = int(next(line.split()[1] for line in done.stdout.splitlines() if line.startswith("peak_kb")))
    summary = next((line for line in done.stdout.splitlines() if "wrote" in line), "")
    return wall, peak_kb / 1024, summary


def main() -> None:
    slices = int(sys.argv[1]) if len(sys.argv) > 1 else 250
    decoded_gb = slices * SIDE_PX * SIDE_PX * 2 / 1e9
    print(f"stack: {slices} × {SIDE_PX} × {SIDE_PX} uint16 = {decoded_gb:.2f} GB decoded\n")
    print("| input | written s | convert s | peak RSS MB | under 1 GB |")
    print("|---|---:|---:|---:|---|")
    ok = True
    with tempfile.TemporaryDirectory(dir=os.environ.get("TMPDIR")) as tmp:
        for name, writer in (("stack.zarr", write_zarr), ("stack.ome.tif", write_ome_tiff)):
            path = Path(tmp) / name
            start = time.perf_counter()
            writer(path, slices)
            written = time.perf_counter() - start
            wall, peak_mb, summary = convert(path, Path(tmp) / "out")
            ok &= peak_mb < LIMIT_MB
            print(f"| {'OME-Zarr folder' if name.endswith('zarr') else 'OME-TIFF'} | {written:.0f} | {wall:.1f} | {peak_mb:.0f} | "
                  f"{'yes' if peak_mb < LIMIT_MB else 'NO'} |", flush=True)
            import shutil

            shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink()
    if not ok:
        raise SystemExit("peak memory above 1 GB")


if __name__ == "__main__":
    main()
