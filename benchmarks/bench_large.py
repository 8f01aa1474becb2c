"""A whole slide and a large print, each as one `tamp-os convert` process (issue 37.4 and 37.5):
wall time, CPU time and peak resident memory.

    .venv/bin/python benchmarks/bench_large.py [--runs 1] [--only slide|print]

- **Whole slide**: a pyramidal OME-TIFF of 100,000 × 80,000 RGB pixels (24 GB decoded) with
  seven levels, each half the one above. Levels 0-4 are black: every tile is the same zlib
  stream, written once compressed (a reader that decoded level 0 would need 24 GB and minutes,
  though the file is small); level 5
  (3125 × 2500) and the smaller ones hold the H&E skin section of `aperio_cmu1_he_skin.svs`,
  so the level the reader should choose (the smallest at least 2048 px wide) is a real picture.
  The target: ≤ 10 s and ≤ 1 GB, level 0 never decoded.
- **Large print**: the FePt picture at the High preset, 200 mm wide (High's 0.2 mm pitch: a
  1000 × 750 working grid), a 2000 × 2000 noise picture the same way (1000 × 1000; noise is the
  worst case for the adaptive mesh), and that picture on a 2000 × 2000 grid (`--resolution-px
  2000`, 0.1 mm), STL.
  The target: ≤ 10 s and ≤ 2 GB, the mesh within half a layer (the adaptive mesher's default
  error bound, `max_error_mm` = layer / 2).
"""

from __future__ import annotations

import argparse
import itertools
import os
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT.parent / "shared" / "fixtures"
SLIDE_PX = (80_000, 100_000)  # rows, cols of level 0
LEVELS = 7


def _env() -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # an installed package has its bytecode cached
    return env


def write_slide(path: Path) -> tuple[int, int]:
    """The pyramidal OME-TIFF described above; returns the (rows, cols) of the level with content."""
    import numpy as np
    import tifffile
    from PIL import Image

    with tifffile.TiffFile(FIXTURES / "real" / "aperio_cmu1_he_skin.svs") as svs:
        tissue = Image.fromarray(svs.pages[0].asarray())
    rows, cols = SLIDE_PX
    shapes = [(rows >> k, cols >> k) for k in range(LEVELS)]
    black = zlib.compress(bytes(512 * 512 * 3))

    def black_tiles(r, c):
        return itertools.repeat(black, -(-r // 512) * -(-c // 512))

    with tifffile.TiffWriter(path, bigtiff=True, ome=True) as tif:
        meta = {"axes": "YXS", "PhysicalSizeX": 0.25, "PhysicalSizeXUnit": "µm", "PhysicalSizeY": 0.25, "PhysicalSizeYUnit": "µm"}
        tif.write(black_tiles(*shapes[0]), shape=(*shapes[0], 3), dtype=np.uint8, tile=(512, 512), compression="zlib",
                  subifds=LEVELS - 1, metadata=meta, photometric="rgb")
        for k in range(1, LEVELS):
            r, c = shapes[k]
            if k < 5:
                tif.write(black_tiles(r, c), shape=(r, c, 3), dtype=np.uint8, tile=(512, 512), compression="zlib",
                          subfiletype=1, photometric="rgb")
            else:
                level = np.asarray(tissue.resize((c, r), Image.Resampling.LANCZOS))
                tif.write(level, tile=(256, 256), subfiletype=1, photometric="rgb", compression="zlib")
    return shapes[5]


MEASURE = ("import resource, subprocess, sys, time; t = time.perf_counter(); "
           "done = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
           "r = resource.getrusage(resource.RUSAGE_CHILDREN); "
           "print(time.perf_counter() - t, r.ru_utime + r.ru_stime, r.ru_maxrss / 1024, done.returncode); "
           "print(done.stdout[-1500:] + done.stderr[-1500:], file=sys.stderr)")


def measured(args: list[str]) -> tuple[float, float, float, int, str]:
    """(wall s, CPU s, peak RSS MB, exit code, output) of `tamp-os ARGS` as a new process."""
    done = subprocess.run([sys.executable, "-c", MEASURE, sys.executable, "-m", "tamp_os.cli", *args],
                          capture_output=True, text=True, env=_env())
    wall, cpu, peak, code = done.stdout.split()
    return float(wall), float(cpu), float(peak), int(code), done.stderr


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--only", choices=("slide", "print"))
    args = parser.parse_args()
    import numpy as np
    from PIL import Image

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        cases = []
        if args.only in (None, "slide"):
            slide = out / "slide.ome.tif"
            level = write_slide(slide)
            size_mb = os.path.getsize(slide) / 1e6
            cases.append((f"whole slide 100,000 × 80,000 RGB (a {size_mb:.0f} MB file; "
                          f"level with content {level[1]} × {level[0]}), Medium → STL + 3MF",
                          [str(slide), "-o", str(out / "slide"), "--formats", "stl,3mf"]))
        if args.only in (None, "print"):
            noise = out / "noise_2000.png"
            Image.fromarray(np.random.default_rng(0).integers(0, 256, (2000, 2000), dtype=np.uint8)).save(noise)
            for name, picture, grid in (("FePt SEM 1024 × 768", FIXTURES / "fept_spheres_sem.png", []),
                                        ("noise 2000 × 2000", noise, []),
                                        ("noise 2000 × 2000", noise, ["--resolution-px", "2000"])):
                cases.append((f"{name}, High, 200 mm wide{' (' + ' '.join(grid) + ')' if grid else ''} → STL",
                              [str(picture), "-o", str(out / "print"), "--preset", "high", "--width-mm", "200", "--formats", "stl", *grid]))
        for name, cli in cases:
            runs = [measured(["convert", *cli]) for _ in range(args.runs)]
            best = min(runs)
            if best[3] != 0:
                print(f"{name}: exit {best[3]}\n{best[4]}", file=sys.stderr)
            rows.append(f"| {name} | {best[0]:.1f} | {best[1]:.1f} | {best[2]:.0f} | {best[3]} |")
            print(best[4].strip().splitlines()[-1] if best[4].strip() else "", file=sys.stderr)
    load = os.getloadavg()
    print(f"Whole process, best of {args.runs} (load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} on {os.cpu_count()} cores):\n")
    print("| case | wall s | CPU s | peak RSS MB | exit |")
    print("|---|---:|---:|---:|---:|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
