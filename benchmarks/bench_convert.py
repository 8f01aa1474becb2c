"""Whole-process speed of one conversion, as a user runs it, and where the time goes.

    .venv/bin/python benchmarks/bench_convert.py [--runs 7]

`tamp-os convert fept_spheres_sem.png --formats stl,3mf,glb` (Medium, the defaults) is started as a
new process `--runs` times and timed from start to exit; the per-pixel loop of the reference
algorithm (benchmarks/reference_loop.py) is run the same way, in the same run, for comparison.
Then one conversion in this process gives the time of each stage (the report's timings, plus
imports and writing). Medians; this machine is shared, so single runs vary by ±30 %.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FEPT = ROOT.parent / "shared" / "fixtures" / "fept_spheres_sem.png"
LOOP = f"""
import sys, time
sys.path.insert(0, {str(ROOT / 'benchmarks')!r})
import reference_loop as r
from pathlib import Path
out = Path(sys.argv[1])
h = r.heightmap({str(FEPT)!r}, 256)
verts, faces = r.mesh(h)
(out / 'loop.stl').write_bytes(r.stl_bytes(verts, faces))
(out / 'loop.3mf').write_bytes(r.threemf_bytes(verts, faces))
(out / 'loop.glb').write_bytes(r.glb_bytes(verts, faces))
"""


def wall_s(command: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return time.perf_counter() - start


def whole_process(runs: int, out: Path) -> tuple[float, float]:
    ours = [sys.executable, "-m", "tamp_os.cli", "convert", str(FEPT), "-o", str(out / "ours"), "--formats", "stl,3mf,glb"]
    loop = [sys.executable, "-c", LOOP, str(out)]
    times_ours, times_loop = [], []
    for _ in range(runs):  # alternate, so both see the same load
        times_ours.append(wall_s(ours))
        times_loop.append(wall_s(loop))
    return statistics.median(times_ours), statistics.median(times_loop)


def imports_s(runs: int) -> tuple[float, float]:
    """(Python alone, Python + everything a conversion imports) in a new process."""
    bare = statistics.median(wall_s([sys.executable, "-c", "pass"]) for _ in range(runs))
    code = "import tamp_os.cli, tamp_os.convert, tamp_os.export.stl, tamp_os.export.threemf, tamp_os.export.glb"
    full = statistics.median(wall_s([sys.executable, "-c", code]) for _ in range(runs))
    return bare, full


def stages(out: Path) -> dict[str, float]:
    from tamp_os.convert import convert
    from tamp_os.params import LithoParams

    params = LithoParams(formats=("stl", "3mf", "glb"))
    convert(FEPT, params, out / "warm")  # first call pays one-time costs (caches, lazy imports)
    start = time.perf_counter()
    done = convert(FEPT, params, out / "stages")
    total = time.perf_counter() - start
    timings = dict(done.report.timings_s)
    timings["write (checked as written) and describe"] = total - sum(timings.values())
    return timings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        ours, loop = whole_process(args.runs, out)
        bare, full = imports_s(args.runs)
        parts = stages(out)
    print(f"FePt Medium, image → STL + 3MF + GLB, whole process, median of {args.runs}:\n")
    print("| run | wall s |")
    print("|---|---:|")
    print(f"| per-pixel loop of the reference | {loop:.2f} |")
    print(f"| tamp-os convert (defaults) | {ours:.2f} |\n")
    print("Where tamp-os's time goes:\n")
    print("| stage | s |")
    print("|---|---:|")
    print(f"| Python start | {bare:.3f} |")
    print(f"| imports | {full - bare:.3f} |")
    for name, seconds in parts.items():
        print(f"| {name} | {seconds:.3f} |")


if __name__ == "__main__":
    main()
