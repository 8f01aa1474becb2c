"""Jobs of the web app: each in its own temporary folder, converted in a small thread pool,
removed after its zip is downloaded (after a grace period), when it expires, or when the server
stops.

Every call into the library (make_lithograph, save, the report's keys, rendering) is in
`run_library`, so a change of the library's interface is adapted in one place.
"""

from __future__ import annotations

import io
import re
import shutil
import tempfile
import threading
import time
import uuid
import zipfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import TampError
from ..files import to_uint8, write_png
from ..params import LithoParams
from .uploads import Upload

JOB_ID = re.compile(r"^[0-9a-f]{32}$")
RENDER_LOCK = threading.Lock()  # VTK renders one scene at a time
PREVIEW_SUFFIX = ".preview.glb"  # the 3-D view's model, written whatever formats were chosen


def safe_name(name: str, taken: set[str]) -> str:
    """A file name with no folders, no leading dots and only plain characters, whose stem is unique
    in the job (case-insensitively): 'sample.png' and 'sample.tif' would both write sample.stl."""
    base = Path(name.replace("\\", "/")).name
    base = re.sub(r"[^A-Za-z0-9._-]+", "_", base).lstrip("._") or "image"
    stem, dot, ext = base[:80].rpartition(".")
    if not dot:
        stem, ext = base[:80], ""
    candidate, n = f"{stem}.{ext}" if ext else stem, 1
    while Path(candidate).stem.lower() in taken:
        n += 1
        candidate = f"{stem}_{n}.{ext}" if ext else f"{stem}_{n}"
    taken.add(Path(candidate).stem.lower())
    return candidate


@dataclass
class OutputFile:
    name: str
    size_bytes: int


@dataclass
class Result:
    """One image's outcome, in the words and files the results page shows."""

    name: str
    ok: bool
    error: str = ""
    files: list[OutputFile] = field(default_factory=list)
    description: str = ""  # the plain-language description; also the previews' text alternative
    heightmap_png: str = ""
    render_png: str = ""
    model_glb: str = ""
    summary: list[str] = field(default_factory=list)
    relief_style: str = ""
    relief_reason: str = ""
    touch: list[str] = field(default_factory=list)  # what a finger will find


@dataclass
class WebJob:
    """A web-app job (not to be confused with batch.py's jobs): uploads, settings, results."""

    id: str
    folder: Path
    uploads: list[Upload]
    created: float = field(default_factory=time.time)
    state: str = "added"  # added, running, done
    done: int = 0
    message: str = ""
    params: LithoParams = field(default_factory=LithoParams)
    results: list[Result] = field(default_factory=list)
    delete_after: float | None = None

    @property
    def out(self) -> Path:
        return self.folder / "out"

    @property
    def thumbs(self) -> Path:
        return self.folder / "thumbs"

    def output_names(self) -> set[str]:
        names = {f.name for r in self.results for f in r.files}
        return names | {n for r in self.results for n in (r.heightmap_png, r.render_png, r.model_glb) if n}

    def download_names(self) -> list[str]:
        return sorted(f.name for r in self.results for f in r.files)


class JobStore:
    def __init__(self, root: Path | None = None, workers: int = 2, ttl_s: float = 3600.0, grace_s: float = 60.0, slow_s: float = 0.0):
        self.root = Path(root) if root else Path(tempfile.mkdtemp(prefix="tamp-gui-"))
        self.root.mkdir(parents=True, exist_ok=True)
        self.jobs: dict[str, WebJob] = {}
        self.lock = threading.Lock()
        self.pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="tamp-job")
        self.ttl_s, self.grace_s, self.slow_s = ttl_s, grace_s, slow_s
        self._stop = threading.Event()
        threading.Thread(target=self._sweep, daemon=True, name="tamp-sweeper").start()

    def create(self) -> WebJob:
        job_id = uuid.uuid4().hex
        folder = self.root / job_id
        for sub in ("in", "out", "thumbs"):
            (folder / sub).mkdir(parents=True)
        job = WebJob(id=job_id, folder=folder, uploads=[])
        with self.lock:
            self.jobs[job_id] = job
        return job

    def get(self, job_id: str) -> WebJob | None:
        if not JOB_ID.match(job_id or ""):
            return None
        with self.lock:
            return self.jobs.get(job_id)

    def remove(self, job_id: str) -> None:
        with self.lock:
            job = self.jobs.pop(job_id, None)
        if job:
            shutil.rmtree(job.folder, ignore_errors=True)

    def _sweep(self) -> None:
        while not self._stop.wait(min(5.0, self.grace_s / 2)):
            now = time.time()
            with self.lock:
                expired = [j.id for j in self.jobs.values()
                           if j.state != "running" and (now - j.created > self.ttl_s or (j.delete_after and now > j.delete_after))]
            for job_id in expired:
                self.remove(job_id)

    def close(self) -> None:
        self._stop.set()
        self.pool.shutdown(wait=False, cancel_futures=True)
        shutil.rmtree(self.root, ignore_errors=True)

    def start(self, job: WebJob, params: LithoParams) -> None:
        job.params, job.state, job.done, job.results = params, "running", 0, []
        job.message = f"Converting {len(job.uploads)} image{'s' if len(job.uploads) != 1 else ''}."
        self.pool.submit(self._run, job)

    def _run(self, job: WebJob) -> None:
        for upload in job.uploads:
            job.message = f"Converting {job.done + 1} of {len(job.uploads)}: {upload.name}."
            if self.slow_s:
                time.sleep(self.slow_s)  # test hook: keeps the running state visible long enough to audit
            job.results.append(convert(job, upload))
            job.done += 1
        ok = sum(r.ok for r in job.results)
        job.message = f"Done: {ok} of {len(job.uploads)} converted." + (" Some failed; see below." if ok < len(job.uploads) else "")
        job.state = "done"

    def zip_bytes(self, job: WebJob) -> bytes:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
            for name in job.download_names():
                z.write(job.out / name, name)
        job.delete_after = time.time() + self.grace_s
        return buf.getvalue()


@dataclass
class LibraryOutput:
    """What the web app needs from one made lithograph."""

    files: list[Path]
    heightmap: np.ndarray  # H×W heights, mm
    vertices: np.ndarray  # N×3, mm
    faces: np.ndarray  # M×3 vertex indices
    description: str
    print_mm: tuple[float, float, float]
    grid: tuple[int, int]
    triangles: int
    height_levels: int
    scale: str
    warnings: list[str]
    annotations: list[str]
    printing: str  # the slicer's sentence, or ""
    relief_style: str  # the style that made the heights
    relief_reason: str  # why that style, or what it did
    touch: list[str]  # what a finger will find (legibility verdicts)


def run_library(path: Path, params: LithoParams, out: Path, stem: str) -> LibraryOutput:
    """The one place the web app calls the library: make, save, and read the report."""
    from ..export import save_mesh
    from ..figure import make_figure

    from ..report import touch_notes
    from .forms import plain

    figure = make_figure(path, params)  # one picture, or each panel of a figure and an overview (shown here)
    written = []
    for suffix, litho in figure.prints:
        paths = litho.save(out, stem=stem + suffix)
        if params.gcode:  # saving never slices; slicing is its own step
            from ..slicer import slice_outputs

            paths = slice_outputs(litho, paths)
        written += paths
    meta = litho.metadata()
    save_mesh(litho.mesh, out / f"{stem}{PREVIEW_SUFFIX}", meta)
    r = litho.report
    panels = [f"Panel {s[7:]}: {lit.metadata()['description']}" for s, lit in figure.prints if s.startswith(".panel-")]
    return LibraryOutput(
        files=written, heightmap=litho.heightmap, vertices=litho.mesh.vertices, faces=litho.mesh.faces,
        description=" ".join([meta["description"], *panels]), print_mm=tuple(r.print_mm), grid=tuple(r.grid), triangles=r.triangles,
        height_levels=0 if r.uniform else r.height_levels, scale=r.scale, warnings=list(dict.fromkeys(list(r.warnings) + figure.notes)),
        annotations=list(r.annotations), printing=r.print["summary"] if r.print else "",
        relief_style=r.relief_style, relief_reason=r.relief_reason, touch=[plain(line) for line in touch_notes(r)],
    )


def convert(job: WebJob, upload: Upload) -> Result:
    params = job.params.replace(preset=upload.override) if upload.override else job.params
    stem = Path(upload.name).stem
    try:
        made = run_library(upload.path, params, job.out, stem)
    except TampError as exc:
        return Result(upload.name, False, str(exc).replace(str(upload.path), upload.name))
    except Exception as exc:  # keep the server alive and say what happened
        return Result(upload.name, False, f"{upload.name}: unexpected error ({exc.__class__.__name__}); please report it.")
    gray = to_uint8(made.heightmap)
    result = Result(
        upload.name, True, files=[OutputFile(p.name, p.stat().st_size) for p in made.files],
        description=made.description, heightmap_png=f"{stem}.heightmap.png", model_glb=f"{stem}{PREVIEW_SUFFIX}",
        summary=summary_lines(made, upload), relief_style=made.relief_style, relief_reason=made.relief_reason,
        touch=made.touch,
    )
    write_png(job.out / result.heightmap_png, gray)
    try:
        from ..render import View, render_views

        with RENDER_LOCK:
            full, _ = render_views(made.vertices, made.faces, View(width_px=640, height_px=480))
        result.render_png = f"{stem}.render.png"
        write_png(job.out / result.render_png, full)
    except Exception as exc:  # previews are a help, not the product: report and go on
        result.summary.append(f"No rendered picture: {exc}")
    return result


def summary_lines(made: LibraryOutput, upload: Upload) -> list[str]:
    w, d, top = made.print_mm
    lines = [
        f"Print {w:g} × {d:g} mm, up to {top:g} mm high.",
        f"Grid {made.grid[0]} × {made.grid[1]} points, {made.triangles:,} triangles, "
        + (f"{made.height_levels} height levels." if made.height_levels else "a flat plate."),
        f"Scale: {made.scale}.",
        *[f"Note: {x}" for x in made.warnings],
    ]
    removed = [plain_annotation(a, upload.width, upload.height) for a in made.annotations]
    if removed:
        lines.append("Removed before printing, so they do not print as raised blocks: " + "; ".join(removed) + ".")
    if made.printing:
        lines.append(f"Printing: {made.printing}.")
    return lines


ANNOTATION = re.compile(r"(\w+) at rows (\d+)–(\d+), columns (\d+)–(\d+)")
KINDS = {"box": "a label or scale-bar box", "bar": "a scale bar", "text": "a text label"}


def plain_annotation(text: str, width_px: int, height_px: int) -> str:
    """'box at rows 707–745, columns 10–90' -> 'a label or scale-bar box near the bottom left'."""
    m = ANNOTATION.fullmatch(text)
    if not m:
        return text
    kind, r0, r1, c0, c1 = m.group(1), *map(int, m.groups()[1:])
    row, col = (r0 + r1) / 2 / max(height_px, 1), (c0 + c1) / 2 / max(width_px, 1)
    vertical = "top" if row < 1 / 3 else "bottom" if row > 2 / 3 else "middle"
    horizontal = "left" if col < 1 / 3 else "right" if col > 2 / 3 else "centre"
    where = "the centre" if (vertical, horizontal) == ("middle", "centre") else f"the {vertical} {horizontal}".replace("middle ", "")
    return f"{KINDS.get(kind, kind)} near {where}"
