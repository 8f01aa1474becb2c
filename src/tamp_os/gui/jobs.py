"""Jobs of the web app: each in its own temporary folder, converted in a small thread pool,
removed after its zip is downloaded (after a grace period) or when it expires."""

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


from ..errors import TampError
from ..files import to_uint8, write_png
from ..report import web_summary
from ..params import LithoParams

JOB_ID = re.compile(r"^[0-9a-f]{32}$")
RENDER_LOCK = threading.Lock()  # VTK renders one scene at a time


def safe_name(name: str, taken: set[str]) -> str:
    """A file name with no folders, no leading dots and only plain characters, unique in the job."""
    base = Path(name.replace("\\", "/")).name
    base = re.sub(r"[^A-Za-z0-9._-]+", "_", base).lstrip("._") or "image"
    stem, dot, ext = base[:80].rpartition(".")
    if not dot:
        stem, ext = base[:80], ""
    candidate, n = base[:100], 1
    while candidate.lower() in taken:
        n += 1
        candidate = f"{stem}_{n}.{ext}" if ext else f"{stem}_{n}"
    taken.add(candidate.lower())
    return candidate


@dataclass
class Upload:
    name: str
    path: Path
    width: int
    height: int
    suggested: str
    reason: str
    override: str = ""


@dataclass
class Result:
    name: str
    ok: bool
    error: str = ""
    files: list[str] = field(default_factory=list)
    heightmap_png: str = ""
    heightmap_alt: str = ""
    render_png: str = ""
    render_alt: str = ""
    summary: list[str] = field(default_factory=list)


@dataclass
class Job:
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

    def output_names(self) -> set[str]:
        names = {f for r in self.results for f in r.files}
        names |= {r.heightmap_png for r in self.results if r.heightmap_png} | {r.render_png for r in self.results if r.render_png}
        return names


class JobStore:
    def __init__(self, root: Path | None = None, workers: int = 2, ttl_s: float = 3600.0, grace_s: float = 60.0, slow_s: float = 0.0):
        self.root = Path(root) if root else Path(tempfile.mkdtemp(prefix="tamp-gui-"))
        self.root.mkdir(parents=True, exist_ok=True)
        self.jobs: dict[str, Job] = {}
        self.lock = threading.Lock()
        self.pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="tamp-job")
        self.ttl_s, self.grace_s, self.slow_s = ttl_s, grace_s, slow_s
        self._stop = threading.Event()
        threading.Thread(target=self._sweep, daemon=True, name="tamp-sweeper").start()

    def create(self) -> Job:
        job_id = uuid.uuid4().hex
        folder = self.root / job_id
        (folder / "in").mkdir(parents=True)
        (folder / "out").mkdir()
        job = Job(id=job_id, folder=folder, uploads=[])
        with self.lock:
            self.jobs[job_id] = job
        return job

    def get(self, job_id: str) -> Job | None:
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

    def start(self, job: Job, params: LithoParams) -> None:
        job.params, job.state, job.done, job.results = params, "running", 0, []
        job.message = f"Converting {len(job.uploads)} image{'s' if len(job.uploads) != 1 else ''}."
        self.pool.submit(self._run, job)

    def _run(self, job: Job) -> None:
        for upload in job.uploads:
            job.message = f"Converting {job.done + 1} of {len(job.uploads)}: {upload.name}."
            if self.slow_s:
                time.sleep(self.slow_s)  # test hook: keeps the running state visible long enough to audit
            job.results.append(convert(job, upload))
            job.done += 1
        ok = sum(r.ok for r in job.results)
        job.message = f"Done: {ok} of {len(job.uploads)} converted." + (" Some failed; see below." if ok < len(job.uploads) else "")
        job.state = "done"

    def zip_bytes(self, job: Job) -> bytes:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
            for name in sorted(job.output_names()):
                z.write(job.out / name, name)
        job.delete_after = time.time() + self.grace_s
        return buf.getvalue()


def convert(job: Job, upload: Upload) -> Result:
    from ..pipeline import make_lithograph
    from ..render import View, render_views

    params = job.params.replace(preset=upload.override) if upload.override else job.params
    stem = Path(upload.name).stem
    try:
        litho = make_lithograph(upload.path, params)
        written = litho.save(job.out, stem=stem)
        if params.gcode:
            from ..slicer import slice_outputs

            written = slice_outputs(litho, written)
    except TampError as exc:
        return Result(upload.name, False, str(exc).replace(str(upload.path), upload.name))
    except Exception as exc:  # keep the server alive and say what happened
        return Result(upload.name, False, f"{upload.name}: unexpected error ({exc.__class__.__name__}); please report it.")
    heightmap_png = f"{stem}.heightmap.png"
    write_png(job.out / heightmap_png, to_uint8(litho.heightmap))
    w, d, _ = litho.report.print_mm
    result = Result(
        upload.name, True, files=[p.name for p in written], heightmap_png=heightmap_png,
        heightmap_alt=(f"Heightmap of {upload.name}: brighter means higher on the print; "
                       f"{'dark' if params.invert else 'bright'} parts of the image are raised."),
        summary=web_summary(litho.report),
    )
    try:
        with RENDER_LOCK:
            full, _ = render_views(litho.mesh.vertices, litho.mesh.faces, View(width_px=640, height_px=480))
        result.render_png = f"{stem}.render.png"
        write_png(job.out / result.render_png, full)
        result.render_alt = (f"Rendered view of the printable relief of {upload.name}, {w:g} by {d:g} mm, seen from the front left "
                             f"and above, lit from the upper left.")
    except Exception as exc:  # previews are a help, not the product: report and go on
        result.summary.append(f"No rendered preview: {exc}")
    return result
