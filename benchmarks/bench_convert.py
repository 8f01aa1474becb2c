"""Whole-process speed of one conversion, as a user runs it, and where the time goes.

    .venv/bin/python benchmarks/bench_convert.py [--runs 7]
    .venv/bin/python benchmarks/bench_convert.py --wide --runs 1   # 1000 mm at High (issue 40.5)

`tamp-os convert fept_spheres_sem.png --formats stl,3mf,glb` (Medium, the defaults) is started as a
new process `--runs` times and timed from start to exit, wall clock and CPU (user + system of the
process and its children, so Tesseract counts); the per-pixel loop of the reference algorithm
(benchmarks/reference_loop.py) is run the same way, alternating with it, so both see the same load.

Where the time goes comes from new processes too (a conversion in a warm process would hide the
first-call costs a user pays: lazy imports, caches): each run times the Python start, the imports
of the command line, each stage of the pipeline (its wall time and the CPU time of the main
thread) and the writing. The table gives the best of the runs (the machine is shared: the best is
the least disturbed; medians and the spread are printed too) and, for scale, what importing
just the third-party modules the conversion loaded costs on its own.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FEPT = ROOT.parent / "shared" / "fixtures" / "fept_spheres_sem.png"
FORMATS = "stl,3mf,glb"
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
# One `tamp-os convert` in a new process, timed from inside: the imports of the command line, each
# pipeline stage (wall, and CPU of the main thread: the scale-bar reader runs on its own thread),
# and the rest of the command (writing the files, description and recipe, the summary).
STAGED = """
import json, sys, time
start_wall, start_cpu = time.perf_counter(), time.thread_time()
import tamp_os.cli.commands as cli
cli._ONE_COMMAND = True  # as the tamp-os program (cli.run): its imports kept out of the cycle collector
with cli._loading():
    import tamp_os.lithograph.pipeline as pipeline, tamp_os.lithograph.convert, tamp_os.lithograph.outputs
imported_wall, imported_cpu = time.perf_counter(), time.thread_time()
stages = {}

class Clock(pipeline._Clock):
    def __enter__(self):
        self.cpu = time.thread_time()
        super().__enter__()

    def __exit__(self, *exc):
        super().__exit__(*exc)
        stages[self.stage] = (self.timings[self.stage], time.thread_time() - self.cpu)

pipeline._Clock = Clock
code = cli.main(["convert", sys.argv[1], "-o", sys.argv[2], "--formats", sys.argv[3]])
end_wall, end_cpu = time.perf_counter(), time.thread_time()
# A lazy module (NumPy's tools the program defers) loads at its first attribute read: left out, unread.
third_party = [m for m, module in list(sys.modules.items()) if m.split(".")[0] not in sys.stdlib_module_names
               and not m.startswith(("tamp_os", "_")) and type(module).__name__ != "_LazyModule"
               and getattr(module, "__file__", None)]
stages["write, describe, recipe, summary"] = (
    end_wall - imported_wall - sum(w for w, _ in stages.values()), end_cpu - imported_cpu - sum(c for _, c in stages.values()))
print(json.dumps({"code": code, "imports": (imported_wall - start_wall, imported_cpu - start_cpu),
                  "stages": stages, "third_party": third_party}))
"""
FLOOR = """
import importlib, json, sys
for name in json.load(open(sys.argv[1])):
    try:
        importlib.import_module(name)
    except Exception:
        pass
"""


def _env(src: Path | None = None) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src or ROOT / "src"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's installed package has its bytecode cached
    return env


def timed(command: list[str], src: Path | None = None) -> tuple[float, float, str]:
    """(wall s, CPU s of the process and its children, stdout) of one new process (`src`: the
    package's sources to run, by default this tree's)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    out = subprocess.run(command, check=True, capture_output=True, text=True, env=_env(src))
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), out.stdout


def spread(values: list[float]) -> str:
    return f"best {min(values):.2f}, median {statistics.median(values):.2f}, worst {max(values):.2f}"


def wide(runs: int) -> None:
    """`--wide`: 1000 mm at the High preset (issue 40.5), a 160 x 120 noise picture and FePt, STL:
    wall, CPU and peak resident memory of each whole process (best of `runs`). The target: within
    20 s and 1 GB. Measured on this shared 2-core machine, one run each: before the bound on the
    working grid (commit c519e8f, load average about 6) noise 384 s and 2,256 MB, FePt 152 s and
    2,145 MB; after it (load average 2.8) noise 30.6 s (22.3 s CPU, of which the adaptive mesh of
    the 5001 x 3751 grid about 10 s) and 816 MB, FePt 7.7 s and 711 MB; with the mesh outline from
    the rectangle's sides and one pydelatin pass where the first leaves the peak out (load average
    about 2) noise 13.2 s (11.9 s user + 2.1 s system) and 784 MB, FePt 6.8 s and 721 MB."""
    import numpy as np
    from PIL import Image

    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        noise = out / "noise_160x120.png"
        Image.fromarray(np.random.default_rng(0).integers(0, 256, (120, 160), dtype=np.uint8)).save(noise)
        print(f"1000 mm at High, image → STL, whole process, best of {runs} (load average {os.getloadavg()[0]:.1f} "
              f"on {os.cpu_count()} cores):\n")
        print("| picture | wall s | CPU s | peak MB |")
        print("|---|---:|---:|---:|")
        for name, image in (("noise 160 × 120", noise), ("FePt SEM", FEPT)):
            rows = []
            for _ in range(runs):
                # a new process per run: its own peak (ru_maxrss of the children is the largest child's)
                code = (f"import resource, subprocess, sys, time; t = time.perf_counter(); "
                        f"subprocess.run([sys.executable, '-m', 'tamp_os.cli', 'convert', {str(image)!r}, '-o', {str(out / 'wide')!r}, "
                        f"'--width-mm', '1000', '--preset', 'high', '--formats', 'stl'], check=True, capture_output=True); "
                        f"r = resource.getrusage(resource.RUSAGE_CHILDREN); "
                        f"print(time.perf_counter() - t, r.ru_utime + r.ru_stime, r.ru_maxrss / 1024)")
                rows.append(tuple(float(v) for v in subprocess.run([py, "-c", code], check=True, capture_output=True,
                                                                    text=True, env=_env()).stdout.split()))
            print(f"| {name} | {min(r[0] for r in rows):.1f} | {min(r[1] for r in rows):.1f} | {min(r[2] for r in rows):.0f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--wide", action="store_true", help="only the 1000 mm, High rows (issue 40.5)")
    parser.add_argument("--before", type=Path, metavar="SRC",
                        help="also time the command line of another tree's sources (e.g. `git archive main src`), alternating")
    args = parser.parse_args()
    if args.wide:
        return wide(max(1, min(args.runs, 3)))
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        timed([py, "-m", "tamp_os.cli.commands", "convert", str(FEPT), "-o", str(out / "warmup"), "--formats", FORMATS])  # bytecode, disk cache
        ours, loop, bare, staged, before = [], [], [], [], []
        if args.before:
            timed([py, "-m", "tamp_os.cli.commands", "convert", str(FEPT), "-o", str(out / "warmup"), "--formats", FORMATS], args.before)
        for _ in range(args.runs):  # alternate, so every measurement sees the same load
            if args.before:
                before.append(timed([py, "-m", "tamp_os.cli.commands", "convert", str(FEPT), "-o", str(out / "before"),
                                     "--formats", FORMATS], args.before)[:2])
            ours.append(timed([py, "-m", "tamp_os.cli.commands", "convert", str(FEPT), "-o", str(out / "ours"), "--formats", FORMATS])[:2])
            loop.append(timed([py, "-c", LOOP, str(out)])[:2])
            bare.append(timed([py, "-c", "pass"])[:2])
            staged.append(json.loads(timed([py, "-c", STAGED, str(FEPT), str(out / "staged"), FORMATS])[2].splitlines()[-1]))
        modules = out / "third_party.json"
        modules.write_text(json.dumps(staged[0]["third_party"]))
        floor = [timed([py, "-c", FLOOR, str(modules)])[:2] for _ in range(args.runs)]
    load = os.getloadavg()
    print(f"FePt Medium, image → STL + 3MF + GLB, whole process, {args.runs} runs each "
          f"(load average {load[0]:.1f} / {load[1]:.1f} on {os.cpu_count()} cores):\n")
    print("| run | wall s (best) | wall s (median) | CPU s (best) |")
    print("|---|---:|---:|---:|")
    rows = [("per-pixel loop of the reference", loop)] + ([(f"tamp-os convert, {args.before}", before)] if before else [])
    for name, runs in rows + [("tamp-os convert (defaults)", ours)]:
        print(f"| {name} | {min(w for w, _ in runs):.2f} | {statistics.median(w for w, _ in runs):.2f} | {min(c for _, c in runs):.2f} |")
    for name, runs in rows[1:] + [("tamp-os convert (defaults)", ours)]:
        print(f"\n{name} / loop: wall {statistics.median(w for w, _ in runs) / statistics.median(w for w, _ in loop):.2f}× "
              f"(medians), CPU {min(c for _, c in runs) / min(c for _, c in loop):.2f}× (best)")
    print(f"\nwall s, tamp-os: {spread([w for w, _ in ours])}; loop: {spread([w for w, _ in loop])}")
    print("\nWhere tamp-os's time goes (best of the runs, ms; CPU of the main thread):\n")
    print("| stage | wall ms | CPU ms |")
    print("|---|---:|---:|")
    print(f"| Python start | {1000 * min(w for w, _ in bare):.0f} | {1000 * min(c for _, c in bare):.0f} |")
    print(f"| imports of the command line | {1000 * min(s['imports'][0] for s in staged):.0f} | {1000 * min(s['imports'][1] for s in staged):.0f} |")
    for name in staged[0]["stages"]:
        walls = [s["stages"][name][0] for s in staged if name in s["stages"]]
        cpus = [s["stages"][name][1] for s in staged if name in s["stages"]]
        print(f"| {name} | {1000 * min(walls):.0f} | {1000 * min(cpus):.0f} |")
    print(f"\nFor scale: importing only the {len(staged[0]['third_party'])} third-party modules this conversion loads "
          f"(NumPy, SciPy, scikit-image, Pillow, lib3mf, manifold3d, ...) takes {min(w for w, _ in floor):.2f} s wall, "
          f"{min(c for _, c in floor):.2f} s CPU (best of {args.runs}), Python's start included.")


if __name__ == "__main__":
    main()
