"""Batch benchmark: 200 images of 1024 × 768 (copies of the FePt and Zeiss fixtures, each with
its own name) to STL + 3MF at Medium, with 1 and 2 worker processes on this machine.

    .venv/bin/python benchmarks/bench_batch.py [COUNT]
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

from tamp_os import LithoParams
from tamp_os.lithograph.batch import Job, collect_inputs, run_batch

FIXTURES = Path(__file__).resolve().parents[1] / ".." / "shared" / "fixtures"


def main() -> None:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    sources = [FIXTURES / "fept_spheres_sem.png", FIXTURES / "test_tiff_Zeiss_SEM_1k.tif"]
    params = LithoParams(preset="medium", formats=("stl", "3mf"))
    print("| images | workers | wall s | images/s | speed-up |")
    print("|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "in"
        inputs.mkdir()
        for i in range(count):
            src = sources[i % 2]
            shutil.copy(src, inputs / f"img{i:03d}{src.suffix}")
        first = None
        for workers in (1, 2):
            out = Path(tmp) / f"out{workers}"
            jobs = [Job(p, out, params) for p, _ in collect_inputs([inputs])]
            start = time.perf_counter()
            outcomes = run_batch(jobs, out, workers=workers)
            wall = time.perf_counter() - start
            assert all(o["status"] == "converted" for o in outcomes), [o["error"] for o in outcomes if o["error"]]
            first = first or wall
            print(f"| {count} | {workers} | {wall:.1f} | {count / wall:.1f} | {first / wall:.2f}× |")


if __name__ == "__main__":
    main()
