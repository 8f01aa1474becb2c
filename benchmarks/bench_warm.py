"""Warm per picture: one `convert` to STL + 3MF + GLB (defaults) in a process that has already
converted once, and where the time goes, stage by stage (issue 37.1).

    .venv/bin/python benchmarks/bench_warm.py [--runs 7] [PICTURE ...]

Default pictures: the FePt spheres (JPEG, 1024 × 768, a burned-in "4 µm" box read by OCR), the
FEI SiO2 particles at 35 kx and 10 kx (FEI TIFFs, 712 × 484, whose databar box holds the only
scale: its label is read by OCR; 4 and 10 label crops go to OCR) and the TVIPS camera frame
(1024 × 1024, a burned-in "200 nm" box; the scale is in the file, so no OCR).
Each picture is converted once to warm the process (imports, OCR model, caches of first use), then
`--runs` times in two ways, alternating so both see the same load:

- "new picture": the process's caches of this picture's content are emptied first (the OCR
  cache and the furnished plate's, when the code has them), as for the next file of a batch;
- "again": the same picture converted again (a sweep, the web app's second try of a setting).

The stage table gives the median wall time of each stage, its share of the median total, and the
CPU time of the main thread (steadier than wall on a shared machine).
Stages come from the pipeline's own clock (`pipeline._Clock`) and from wrapping the functions
that write the files; the OCR of a scale bar's label runs on its own thread beside the relief,
so it is a row of its own ("beside") and not part of the total: the main thread only waits for
it in "scale bar wait".
"""

from __future__ import annotations

import argparse
import functools
import os
import resource
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT.parent / "shared" / "fixtures"
PICTURES = (FIXTURES / "fept_spheres_sem.png", FIXTURES / "real" / "sem_fei_sio2_particles_35kx.tif",
            FIXTURES / "real" / "sem_fei_sio2_particles_10kx.tif", FIXTURES / "real" / "tvips_bin4.tif")
FORMATS = ("stl", "3mf", "glb")


class Stages:
    """(wall s, CPU s of the calling thread) per stage of the current run, filled by the wrappers below."""

    def __init__(self):
        self.now: dict[str, tuple[float, float]] = {}

    def add(self, name: str, wall: float, cpu: float) -> None:
        w, c = self.now.get(name, (0.0, 0.0))
        self.now[name] = (w + wall, c + cpu)

    def timed(self, function, name):
        """`function`, adding its wall and thread CPU time to stage `name` (a callable of the
        arguments gives the name per call)."""

        @functools.wraps(function)
        def timed(*args, **kwargs):
            wall, cpu = time.perf_counter(), time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                self.add(name(*args) if callable(name) else name, time.perf_counter() - wall, time.thread_time() - cpu)

        return timed

    def wrap(self, module, attribute: str, name) -> None:
        setattr(module, attribute, self.timed(getattr(module, attribute), name))


def instrument(stages: Stages) -> None:
    """Wrap the pipeline's clock and the writers so that each run fills `stages.now`."""
    import tamp_os.clean.annotations as marks
    import tamp_os.clean.stage as clean_stage
    import tamp_os.lithograph.figure as figure
    import tamp_os.lithograph.outputs as outputs
    import tamp_os.lithograph.pipeline as pipeline
    from tamp_os.export import threemf

    class Clock(pipeline._Clock):
        def __enter__(self):
            self.cpu = time.thread_time()
            super().__enter__()

        def __exit__(self, *exc):
            super().__exit__(*exc)
            stages.add(self.stage, self.timings[self.stage], time.thread_time() - self.cpu)

    pipeline._Clock = Clock
    stages.wrap(figure, "make_lithograph", "make_lithograph")  # its clocks' rest: report, words
    stages.wrap(marks, "inpaint", "  of which inpainting")
    stages.wrap(pipeline, "add_furniture", "  of which furniture (plan, fuse)")
    stages.wrap(clean_stage, "_scale_from_bars", "beside: scale-bar OCR (own thread)")
    if hasattr(outputs, "check_written_solid"):  # since issue 37's fourth round: beside the writes, inside their wall
        stages.wrap(outputs, "check_written_solid", "check mesh as written")
    else:
        stages.wrap(outputs, "check_export", "check mesh as written")
    stages.wrap(outputs, "metadata", "metadata and description")
    stages.wrap(outputs, "write_recipe", "recipe")
    stages.wrap(outputs, "save_mesh", lambda mesh, path, *rest: f"write {Path(path).suffix[1:].upper()}")
    stages.wrap(outputs, "write_meshes", "  writes, side by side (wall)")  # the rows above overlap in time
    if hasattr(threemf, "_without_model_relationships"):
        stages.wrap(threemf, "_without_model_relationships", "  of which 3MF re-zip")


def _process_cpu() -> float:
    """CPU seconds of this process (all threads) and of its finished children (a tesseract command)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def forget_picture() -> None:
    """Empty what a process keeps of a picture's content (none before the OCR cache existed) and
    of its print's shape (the furnished plate, kept since issue 37: a picture of another size or
    scale bar gets a plate of its own)."""
    import tamp_os.clean.scalebar as scalebar
    import tamp_os.tactile.furniture as furniture

    for clear in (getattr(scalebar, "clear_ocr_cache", None), getattr(furniture, "clear_plate_cache", None)):
        if clear is not None:
            clear()


PIPELINE = ("read", "annotations", "preprocess", "relief", "legibility", "mesh", "scale bar wait", "tactile", "agreement")


def table(name: str, runs: list[dict[str, tuple[float, float]]]) -> list[str]:
    total = [statistics.median(r["total"][i] for r in runs) for i in (0, 1)]
    rows = [f"| {name}: stage | wall ms | share | CPU ms |", "|---|---:|---:|---:|"]

    def row(label, values=None):
        values = values if values is not None else [r.get(label, (0.0, 0.0)) for r in runs]
        wall, cpu = (1000 * statistics.median(v[i] for v in values) for i in (0, 1))
        rows.append(f"| {label} | {wall:.0f} | {wall / (1000 * total[0]):.0%} | {cpu:.0f} |")

    def minus(r, key, keys):
        return tuple(r.get(key, (0.0, 0.0))[i] - sum(r.get(k, (0.0, 0.0))[i] for k in keys) for i in (0, 1))

    row("figure (panel detection)", [minus(r, "figure", ["make_lithograph"]) for r in runs])
    for stage in PIPELINE:
        row(stage)
        if stage == "annotations":
            row("  of which inpainting")
        if stage == "tactile":
            row("  of which furniture (plan, fuse)")
    row("report and words", [minus(r, "make_lithograph", PIPELINE) for r in runs])
    writes = ("check mesh as written", "write STL", "write 3MF", "write GLB", "metadata and description", "recipe")
    for stage in writes:
        row(stage)
        if stage == "write 3MF" and any("  of which 3MF re-zip" in r for r in runs):
            row("  of which 3MF re-zip")
        if stage == "write GLB" and any("  writes, side by side (wall)" in r for r in runs):
            row("  writes, side by side (wall)")
    row("rest (files, figure's finish)", [minus(r, "total", ("figure",) + writes) for r in runs])
    rows.append(f"| **total** | **{1000 * total[0]:.0f}** | 100% | **{1000 * total[1]:.0f}** |")
    beside = statistics.median(r.get("beside: scale-bar OCR (own thread)", (0.0, 0.0))[0] for r in runs)
    rows.append(f"| beside: scale-bar OCR (own thread, wall; not in the total) | {1000 * beside:.0f} | | |")
    everything = 1000 * statistics.median(r["process"][1] for r in runs)
    rows.append(f"| CPU of every thread and child process (Tesseract's included) | | | {everything:.0f} |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("pictures", nargs="*", type=Path, default=list(PICTURES))
    args = parser.parse_args()
    import logging

    logging.disable(logging.WARNING)  # the pictures' own warnings, once per run, are not the point here
    from tamp_os import LithoParams
    import tamp_os.lithograph.convert as convert_module
    import tamp_os.lithograph.figure as figure

    stages = Stages()
    instrument(stages)
    stages.wrap(figure, "make_figure", "figure")  # convert imports it from the module when called
    params = LithoParams(formats=FORMATS)
    with tempfile.TemporaryDirectory() as tmp:
        for picture in args.pictures:
            convert_module.convert(picture, params, tmp)  # warm: imports, OCR model, first-use caches
            results = {"new picture": [], "again": []}
            for _ in range(args.runs):
                for mode in results:
                    if mode == "new picture":
                        forget_picture()
                    stages.now = {}
                    wall, cpu, process = time.perf_counter(), time.thread_time(), _process_cpu()
                    convert_module.convert(picture, params, tmp)
                    stages.now["total"] = (time.perf_counter() - wall, time.thread_time() - cpu)
                    stages.now["process"] = (0.0, _process_cpu() - process)
                    results[mode].append(stages.now)
            load = os.getloadavg()
            print(f"\n{picture.name}, warm, STL + 3MF + GLB, median of {args.runs} (load average {load[0]:.1f} / "
                  f"{load[1]:.1f} / {load[2]:.1f} on {os.cpu_count()} cores)\n")
            for mode, runs in results.items():
                print("\n".join(table(f"{picture.name} ({mode})", runs)) + "\n")


if __name__ == "__main__":
    main()
