"""Batch conversion that never loses work.

Each input is converted in a worker process by `convert_one` (a plain module-level function, so
any concurrent.futures-style executor can run it: a local process pool or a Dask cluster's
executor). A failing input is reported and the others go on. Outputs are written atomically and
the recipe last, so an input whose recipe matches (same input hash, same parameters, outputs
present) is complete: a rerun skips it and redoes only the rest. The report is rewritten after
every input, so even a killed batch leaves an accurate batch-report.csv/json.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import fnmatch
import functools
import io
import json
import logging
import os
import queue
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from ..errors import InputError, ParameterError, TampError
from ..params import LithoParams, parse_field

log = logging.getLogger(__name__)

IMAGE_PATTERNS = ("*.png", "*.jpg", "*.jpeg", "*.tif", "*.tiff", "*.bmp", "*.gif", "*.webp", "*.dm3", "*.dm4")
# Microscope vendors' formats (vendor_read/): OME-Zarr is a folder; a TIA .ser beside its .emi is one image.
VENDOR_PATTERNS = ("*.czi", "*.lif", "*.nd2", "*.zarr", "*.emi", "*.ser", "*.emd", "*.hspy", "*.mrc", "*.map", "*.img",
                   "*.elid", "*.svs", "*.oib", "*.oif")
IMAGE_PATTERNS = IMAGE_PATTERNS + VENDOR_PATTERNS
FOLDER_FORMATS = (".zarr",)


def _tia_ser_of_emi(path: Path) -> bool:
    """A TIA 'name_1.ser' whose 'name.emi' is beside it: the .emi is converted, the .ser is its data."""
    import re

    match = re.fullmatch(r"(.+)_\d+", path.stem)
    return path.suffix.lower() == ".ser" and match is not None and any(
        (path.parent / (match.group(1) + ext)).exists() for ext in (".emi", ".EMI"))
REPORT_NAME = "batch-report"


@dataclass
class Job:
    source: Path
    out_dir: Path
    params: LithoParams
    stem: str = ""  # output name; the input's stem unless two inputs would share it

    def __post_init__(self):
        self.stem = self.stem or self.source.stem


def name_jobs(jobs: list[Job]) -> list[Job]:
    """Give inputs that would write the same output names (a.png, a.tif) distinct stems (a_png, a_tif)."""
    from .outputs import distinct_stems

    for folder in {job.out_dir for job in jobs}:
        same = [job for job in jobs if job.out_dir == folder]
        for job, stem in zip(same, distinct_stems([job.source for job in same])):
            job.stem = stem
    return jobs


@dataclass
class Outcome:
    input: str
    status: str  # converted, skipped (up to date), failed
    outputs: list[str] = field(default_factory=list)
    seconds: float = 0.0
    error: str = ""
    warnings: list[str] = field(default_factory=list)  # the print's warnings (a flat plate is named here)
    touch: list[str] = field(default_factory=list)  # what a finger will find (legibility verdicts)


def collect_inputs(items, recursive: bool = False, include: tuple[str, ...] | None = None, *, exclude_dir: Path | None = None):
    """(file, path relative to its root) for each image named or found in the folders given."""
    patterns = tuple(p.lower() for p in (include or IMAGE_PATTERNS))
    found = []
    for item in map(Path, items):
        if item.is_dir() and item.suffix.lower() not in FOLDER_FORMATS:
            walker = item.rglob("*") if recursive else item.glob("*")
            excluded = os.path.realpath(exclude_dir) if exclude_dir else None
            for path in sorted(walker):
                if excluded and os.path.realpath(path).startswith(excluded + os.sep):
                    continue
                # Regular files, and anything else with an image's name (a FIFO, a broken or looping
                # link): those are reported as failed by the reader, never allowed to stop the batch.
                wanted = any(fnmatch.fnmatch(path.name.lower(), p) for p in patterns)
                folder_image = path.is_dir() and path.suffix.lower() in FOLDER_FORMATS
                if any(parent.suffix.lower() in FOLDER_FORMATS for parent in path.relative_to(item).parents):
                    continue  # inside an OME-Zarr folder: its chunks, not images
                if wanted and (path.is_file() or not path.is_dir() or folder_image) and not _tia_ser_of_emi(path):
                    found.append((path, path.relative_to(item)))
        else:
            found.append((item, Path(item.name)))  # named explicitly: converted (or reported) as is
    return found


def read_overrides(path: Path) -> dict[str, dict]:
    """Per-image parameter changes from a CSV: a 'file' column (name or relative path) + parameters."""
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise InputError(f"{path}: cannot read the overrides CSV ({exc.strerror}).") from None
    rows = list(csv.DictReader(io.StringIO(text)))
    if rows and "file" not in rows[0]:
        raise ParameterError(f"{path}: the overrides CSV needs a 'file' column; it has {', '.join(rows[0])}.")
    overrides = {}
    for number, row in enumerate(rows, start=2):
        where = f"{path} line {number}"
        try:
            changes = {k: parse_field(k, v) for k, v in row.items() if k != "file" and v and v.strip()}
            LithoParams().replace(**changes)  # validate now, not in the middle of the batch
        except ParameterError as exc:  # a bad cell: the file is the problem (exit 1), named by its own columns
            raise InputError(f"{where}: {exc}", in_file=True) from None
        overrides[row["file"].strip()] = changes
    return overrides


def convert_one(source: str, out_dir: str, params_json: str, *, stem: str) -> dict:
    """Convert one input in a worker; never raises for a user-facing problem."""
    from .products import convert
    from .outputs import RECIPE_SUFFIX, recipe_outputs_if_current

    start = time.perf_counter()
    reuse_freed_arrays()  # a worker that was not started by warm_worker (a Dask cluster's)
    src, out = Path(source), Path(out_dir)
    params = LithoParams.from_json(params_json)
    done = recipe_outputs_if_current(out / f"{stem}{RECIPE_SUFFIX}", src, params)
    if done:
        return dataclasses.asdict(Outcome(str(src), "skipped (up to date)", done, time.perf_counter() - start))
    try:
        made = convert(src, params, out, stem=stem)
    except TampError as exc:  # exc.text() keeps the parameter names for the CLI to say as options
        return dataclasses.asdict(Outcome(str(src), "failed", [], time.perf_counter() - start, exc.text()))
    except Exception as exc:  # a bug must not stop the batch either; report it plainly
        log.exception("unexpected error on %s", src)
        return dataclasses.asdict(Outcome(str(src), "failed", [], time.perf_counter() - start, f"{src}: unexpected error: {exc!r}"))
    warnings = [str(w) for w in made.warnings] if made.model is not None else made.warnings
    if any(c.report.uniform for c in made.conversions):
        warnings.insert(0, FLAT_PLATE_NOTE)
    return dataclasses.asdict(Outcome(str(src), "converted", [p.name for p in made.all_written], time.perf_counter() - start,
                                      warnings=warnings, touch=made.touch()))


FLAT_PLATE_NOTE = "flat plate: the image is uniform, so nothing is raised"  # first of a uniform input's warnings

LOCK_NAME = ".tamp-batch.lock"


@contextlib.contextmanager
def _folder_lock(out_dir: Path):
    """Hold an exclusive lock on the output folder (locks.py): a second batch or convert into the
    same folder stops with a clear message instead of mixing its files with this one's."""
    from .locks import folder_lock

    with folder_lock(out_dir, "another batch or convert"):
        yield


def exit_with_parent() -> None:
    """Worker initializer: end this worker when the batch process that started it dies, so a
    killed batch leaves no workers behind (Linux: the kernel's parent-death signal; elsewhere a
    watcher thread that notices the parent is gone)."""
    import signal
    import threading

    parent = os.getppid()
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        pass

    def watch():
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


# A worker of a local pool has one core to itself: the libraries' own thread pools (BLAS, OpenMP in
# Tesseract) and TAMP-OS's helper threads (the scale bar read beside the relief, formats written
# side by side) would otherwise compete with the neighbour worker for the same cores.
ONE_CORE_ENV = {"TAMP_THREADS": "1", "OMP_NUM_THREADS": "1", "OMP_THREAD_LIMIT": "1", "OPENBLAS_NUM_THREADS": "1",
                "MKL_NUM_THREADS": "1", "NUMEXPR_NUM_THREADS": "1"}


def one_core() -> None:
    """Keep this process to one core: the environment above for libraries loaded from now on,
    and the OpenBLAS copies already loaded (NumPy's and SciPy's, inherited from a forked parent)
    told directly."""
    import ctypes

    os.environ.update(ONE_CORE_ENV)
    try:
        with open("/proc/self/maps") as maps:
            loaded = {line.split()[-1] for line in maps if "openblas" in line.rsplit("/", 1)[-1].lower()}
    except OSError:  # not Linux: the environment is what there is
        return
    for path in loaded:
        with contextlib.suppress(OSError):
            library = ctypes.CDLL(path)
            for name in ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads", "openblas_set_num_threads64_",
                         "openblas_set_num_threads"):
                if hasattr(library, name):
                    getattr(library, name)(ctypes.c_int(1))
                    break


MMAP_THRESHOLD_BYTES = 32 << 20  # glibc's own upper bound for its sliding threshold


@functools.lru_cache(maxsize=1)  # once per process: every worker's first picture (a Dask worker's too)
def reuse_freed_arrays() -> None:
    """Let glibc keep freed blocks up to 32 MB for reuse instead of mapping each array afresh.

    A conversion allocates and frees many arrays of 0.1-30 MB. glibc raises its mmap threshold
    as such blocks are freed, unless MALLOC_TRIM_THRESHOLD_ or MALLOC_MMAP_THRESHOLD_ is set:
    Dask's nanny sets the first for its workers, and then every array over 128 KB is a new
    mapping whose pages the kernel zeroes again (measured: the same 18 conversions took 10.2 s
    of CPU instead of 7.0 s). Setting the threshold here gives back glibc's usual behaviour."""
    import ctypes
    import platform

    if platform.libc_ver()[0] != "glibc":
        return
    with contextlib.suppress(OSError, AttributeError):
        M_MMAP_THRESHOLD = -3
        ctypes.CDLL(None).mallopt(ctypes.c_int(M_MMAP_THRESHOLD), ctypes.c_int(MMAP_THRESHOLD_BYTES))


def warm_worker() -> None:
    """Initializer of the batch's worker processes: end with the parent, keep to one core, and import
    the conversion once, before the first picture (the pool keeps the worker, and so its imports)."""
    exit_with_parent()
    one_core()
    reuse_freed_arrays()
    from . import convert  # noqa: F401  (imported for its side effect: every later picture finds it loaded)


def largest_first(jobs: list[Job]) -> list[int]:
    """The jobs' indices, largest input file first: the long conversions start early, and the last
    ones to finish are short, so no worker idles while another ends a big picture alone."""

    def size(job: Job) -> int:
        try:
            return job.source.stat().st_size if job.source.is_file() else 0
        except OSError:  # a broken link or a FIFO: reported by the worker, in any order
            return 0

    sizes = [size(job) for job in jobs]
    return sorted(range(len(jobs)), key=lambda i: -sizes[i])


def write_report(out_dir: Path, outcomes: list[dict]) -> None:
    from ..export.files import write_text

    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(["input", "status", "outputs", "seconds", "error", "warnings", "touch"])
    for o in outcomes:
        writer.writerow([o["input"], o["status"], " ".join(o["outputs"]), f"{o['seconds']:.3f}", o["error"],
                         " | ".join(o.get("warnings", [])), " ".join(o.get("touch", []))])
    write_text(out_dir / f"{REPORT_NAME}.csv", buf.getvalue())
    text = json.dumps(outcomes, indent=2, ensure_ascii=False) + "\n"
    write_text(out_dir / f"{REPORT_NAME}.json", text)


def run_batch(
    jobs: list[Job],
    out_dir: Path,
    *,
    executor=None,
    workers: int | None = None,
    on_done: Callable[[dict, int, int], None] | None = None,
) -> list[dict]:
    """Run every job on `executor` (any object with submit(fn, *args, **kwargs) -> future), or on a local
    process pool of `workers` processes. Returns the outcomes in input order."""
    from .locks import prepare_folder, sweep_parts

    with _folder_lock(out_dir):
        name_jobs(jobs)
        for folder in {job.out_dir for job in jobs}:
            prepare_folder(folder)
            sweep_parts(folder)  # temporary files of a run that was killed mid-write
        return _run_locked(jobs, out_dir, executor, workers, on_done)


def _run_locked(jobs: list[Job], out_dir: Path, executor, workers: int | None, on_done) -> list[dict]:
    own_pool = executor is None
    if own_pool:
        executor = ProcessPoolExecutor(max_workers=workers or os.cpu_count() or 1, initializer=warm_worker)
    finished: queue.Queue = queue.Queue()
    outcomes: list[dict | None] = [None] * len(jobs)
    try:
        for i in largest_first(jobs):
            job = jobs[i]
            future = executor.submit(convert_one, str(job.source), str(job.out_dir), job.params.to_json(), stem=job.stem)
            future.add_done_callback(lambda f, i=i: finished.put((i, f)))
        for count in range(1, len(jobs) + 1):
            i, future = finished.get()
            try:
                outcome = future.result()
            except BaseException as exc:  # the worker itself died (killed, out of memory)
                outcome = dataclasses.asdict(Outcome(str(jobs[i].source), "failed", [], 0.0, f"{jobs[i].source}: worker failed: {exc!r}"))
            outcomes[i] = outcome
            write_report(out_dir, [o for o in outcomes if o is not None])
            if on_done:
                on_done(outcome, count, len(jobs))
    finally:
        if own_pool:
            executor.shutdown(cancel_futures=True)
    return outcomes  # type: ignore[return-value]
