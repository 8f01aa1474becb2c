"""Jobs of the web app: each in its own temporary folder, converted in a small thread pool, made
again for another printer on request (the same images, captions and settings), kept while its page
is open (the page asks for the job's status now and then), and removed LEFT_GRACES grace periods
after its page was last seen once its zip is downloaded, an hour after it was last seen otherwise, or
when the server stops.

Every call into the library is `run_library` (convert.convert, which makes, saves and slices) and
the report's own sentences (report.web_summary_lines), so the web app rebuilds no text itself.
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


from ..errors import TampError
from ..export.files import to_uint8, write_png
from ..params import LithoParams
from .uploads import Upload

JOB_ID = re.compile(r"^[0-9a-f]{32}$")
RENDER_LOCK = threading.Lock()  # VTK renders one scene at a time
# A downloaded job goes this many grace periods after its page last asked for it: the page asks three
# times a grace period, and a browser slows the timers of a tab in the background (to once a minute)
LEFT_GRACES = 3
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
class Run:
    """The prints of one earlier round of a job, for one printer (kept when it is made again)."""

    printer: str
    results: list[Result]


def printer_slug(printer: str) -> str:
    """'Bambu Lab A1' -> 'bambu-lab-a1': the part of a file name that tells a printer's prints apart."""
    return re.sub(r"[^a-z0-9]+", "-", printer.lower()).strip("-") or "printer"


def _next_round(job: WebJob, printer: str) -> None:
    """Keep this round's prints as an earlier round's; the next round's files carry its `printer`."""
    job.earlier.append(Run(job.params.printer, job.results))
    job.stem_suffix = f"-{printer_slug(printer)}"


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
    stem: str = ""  # its files' common name: the upload's, with a later round's printer ('cells-bambu-lab-a1')
    files: list[OutputFile] = field(default_factory=list)
    description: str = ""  # the plain-language description; also the previews' text alternative
    heightmap_png: str = ""
    render_png: str = ""
    model_glb: str = ""
    summary: list[str] = field(default_factory=list)
    relief_style: str = ""
    relief_reason: str = ""
    touch: list[str] = field(default_factory=list)  # what a finger will find
    prints: list = field(default_factory=list)  # a figure's prints (panel_choice.PrintShown), the overview first
    figure_files: list[OutputFile] = field(default_factory=list)  # a figure's own files (all pages, its recipe)
    left_out: list[str] = field(default_factory=list)  # a figure's panels found but not printed on their own
    volume: bool = False  # a z-stack printed as a 3-D model (no heightmap; the pictures show the model)


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
    downloaded: bool = False  # its zip was downloaded: it goes soon after its page was last seen
    last_seen: float = field(default_factory=time.time)  # any request for it: its pages, status, files
    earlier: list[Run] = field(default_factory=list)  # rounds made for other printers, the first first
    stem_suffix: str = ""  # a round after the first names its files after its printer ('-bambu-lab-a1')
    queued: list = field(default_factory=list)  # LithoParams of the rounds still to make (a second printer)
    rejected: list[str] = field(default_factory=list)  # uploads that were not added, each with its reason
    rejected_announced: bool = False  # the settings page has said them (role alert, focus) once

    @property
    def out(self) -> Path:
        return self.folder / "out"

    @property
    def thumbs(self) -> Path:
        return self.folder / "thumbs"

    def all_results(self) -> list[Result]:
        return [r for run in self.earlier for r in run.results] + self.results

    def output_names(self) -> set[str]:
        results = self.all_results()
        names = {f.name for r in results for f in r.files}
        return names | {n for r in results for n in (r.heightmap_png, r.render_png, r.model_glb) if n}

    def download_names(self) -> list[str]:
        return sorted(f.name for r in self.all_results() for f in r.files)


class JobStore:
    def __init__(self, root: Path | None = None, workers: int = 2, ttl_s: float = 3600.0, grace_s: float = 60.0, slow_s: float = 0.0):
        from .stale import claim, sweep_root, sweep_stale

        if root and Path(root).is_dir():
            sweep_root(Path(root))
        elif not root:
            sweep_stale()  # the folders of servers that were killed before they could clean up
        self.root = Path(root) if root else Path(tempfile.mkdtemp(prefix="tamp-gui-"))
        self.root.mkdir(parents=True, exist_ok=True)
        claim(self.root)
        from .workers import shared_pool

        shared_pool().warm()  # the conversion workers start while the first page loads
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
            job = self.jobs.get(job_id)
        if job is not None:
            job.last_seen = time.time()  # its page is open (it asks for the status) or was just visited
        return job

    def remove(self, job_id: str) -> None:
        with self.lock:
            job = self.jobs.pop(job_id, None)
        if job:
            shutil.rmtree(job.folder, ignore_errors=True)

    def _sweep(self) -> None:
        while not self._stop.wait(min(5.0, self.grace_s / 2)):
            now = time.time()
            with self.lock:
                expired = [j.id for j in self.jobs.values() if j.state != "running"
                           and (now - j.last_seen > self.ttl_s or (j.downloaded and now - j.last_seen > LEFT_GRACES * self.grace_s))]
            for job_id in expired:
                self.remove(job_id)

    def close(self) -> None:
        from .workers import close_shared_pool

        self._stop.set()
        self.pool.shutdown(wait=False, cancel_futures=True)
        close_shared_pool()
        shutil.rmtree(self.root, ignore_errors=True)

    def start(self, job: WebJob, params: LithoParams, then: tuple[LithoParams, ...] = ()) -> None:
        """Convert the job's images with `params`, then again with each of `then` (other printers)."""
        job.params, job.state, job.done, job.results, job.queued = params, "running", 0, [], list(then)
        job.message = f"Converting {len(job.uploads)} image{'s' if len(job.uploads) != 1 else ''}{self._for(job)}."
        self.pool.submit(self._run, job)

    def again(self, job: WebJob, params: LithoParams) -> None:
        """Make the job's prints again with `params` (another printer): the same images, captions and
        settings; the earlier round's files stay, and the new ones carry the printer in their names."""
        _next_round(job, params.printer)
        self.start(job, params)

    @staticmethod
    def _for(job: WebJob) -> str:
        return f" for {job.params.printer}" if job.earlier or job.queued else ""

    def _run(self, job: WebJob) -> None:
        while True:
            for upload in job.uploads:
                job.message = f"Converting {job.done + 1} of {len(job.uploads)}{self._for(job)}: {upload.name}."
                if self.slow_s:
                    time.sleep(self.slow_s)  # test hook: keeps the running state visible long enough to audit
                job.results.append(convert(job, upload))
                job.done += 1
            if not job.queued:
                break
            _next_round(job, job.queued[0].printer)  # a second printer chosen with the first: the same images again
            job.params, job.done, job.results = job.queued.pop(0), 0, []
        ok = sum(r.ok for r in job.results)
        job.message = f"Done: {ok} of {len(job.uploads)} converted{self._for(job)}." + (" Some failed; see below." if ok < len(job.uploads) else "")
        job.state = "done"

    def zip_bytes(self, job: WebJob) -> bytes:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
            names = job.download_names()
            for name in names:
                z.write(job.out / name, name)
            where = {f"{r.stem or Path(r.name).stem}.{p.key}": p.where for r in job.all_results() for p in r.prints if p.where}
            z.writestr("README.txt", readme_text(names, where))
        job.downloaded = True
        return buf.getvalue()


def run_library(path: Path, params: LithoParams, out: Path, *, stem: str):
    """The one place the web app calls the library for a relief: the product entry point (make, save,
    slice) and a preview model."""
    from ..export import save_mesh
    from ..lithograph.products import convert as convert_product

    conversion = convert_product(path, params, out, stem=stem).conversions[0]
    save_mesh(conversion.litho.mesh, out / f"{stem}{PREVIEW_SUFFIX}", conversion.litho.metadata())
    return conversion


def run_volume(path: Path, params: LithoParams, out: Path, *, stem: str):
    """The web app's call for a z-stack printed as a 3-D model: the product entry point, and a preview model."""
    from ..export import save_mesh
    from ..lithograph.products import convert as convert_product
    from ..lithograph.volume import describe_volume

    done = convert_product(path, params, out, stem=stem).model
    meta = {"title": f"Tactile 3-D model of {done.model.name}", "description": describe_volume(done.model)}
    save_mesh(done.model.mesh, out / f"{stem}{PREVIEW_SUFFIX}", meta, checked=True)
    return done


def volume_params(params: LithoParams, upload: Upload) -> LithoParams:
    """`volume` applies to an upload with a z axis only (the others stay reliefs), and a model is
    written as meshes: the flat formats ticked for the reliefs are left out of it (STL when none is left)."""
    from ..formats import MESH_FORMATS

    if not params.volume:
        return params
    if upload.z_slices < 2:
        return params.replace(volume=False)
    meshes = tuple(f for f in params.formats if f in MESH_FORMATS)
    return params.replace(formats=meshes or ("stl",), z_slice=None)


def _in_worker(job: WebJob, upload: Upload, fn, params: LithoParams, stem: str):
    """`fn(path, params, out, stem=)` in the shared worker pool: (its result, None), or (None, the Result
    that says why it failed). One bad upload costs one message, never the server."""
    from .forms import web_words
    from .workers import read_memory_gb, shared_pool

    try:
        return shared_pool().run(upload.name, fn, upload.path, params.replace(max_memory_gb=read_memory_gb()), job.out, stem=stem), None
    except TampError as exc:
        return None, Result(upload.name, False, web_words(exc).replace(str(upload.path), upload.name))
    except Exception as exc:  # keep the server alive and say what happened
        return None, Result(upload.name, False, f"{upload.name}: unexpected error ({exc.__class__.__name__}); please report it.")


def _volume_result(job: WebJob, upload: Upload, params: LithoParams, stem: str) -> Result:
    """A z-stack as a 3-D model: its files, description, facts and a rendered picture."""
    from ..lithograph.volume import describe_volume
    from .forms import web_words

    done, failed = _in_worker(job, upload, run_volume, params, stem)
    if failed is not None:
        return failed
    v = done.model
    result = Result(upload.name, True, files=[OutputFile(p.name, p.stat().st_size) for p in done.written],
                    description=describe_volume(v), model_glb=f"{stem}{PREVIEW_SUFFIX}", volume=True,
                    summary=[done.summary(say_folder=False), *(web_words(line) for line in (*v.warnings, *v.notes))])
    _render_preview(job, result, v.mesh, stem)
    return result


def _render_preview(job: WebJob, result: Result, mesh, stem: str) -> None:
    """The rendered picture of `mesh` beside the result; a failed render is said, not fatal."""
    try:
        from ..lithograph.render import View, render_views

        with RENDER_LOCK:
            full, _ = render_views(mesh.vertices, mesh.faces, View(width_px=640, height_px=480))
        result.render_png = f"{stem}.render.png"
        write_png(job.out / result.render_png, full)
    except Exception as exc:  # previews are a help, not the product: report and go on
        result.summary.append(f"No rendered picture: {exc}")


# What each downloaded file is for that is not one of the formats (theirs come from the format table):
# by a pattern of its name, the first that matches wins.
FILE_PURPOSES = (
    (r"\.description\.txt$", "the print described in words: read it aloud, or use it as the alt text of the picture"),
    (r"\.tamp\.json$", "the recipe: 'tamp-os convert --recipe' rebuilds exactly this print from the same image"),
    (r"\.base\.stl$", "two-colour print, first colour: the plate and relief (load with .raised.stl as two parts)"),
    (r"\.raised\.stl$", "two-colour print, second colour: braille, scale bar and frame (load with .base.stl)"),
    (r"\.sl1s$", "for the resin printer it was sliced for (Original Prusa SL1S): copy it to the printer's USB stick"),
    (r"\.gcode$", "for the printer it was sliced for: send it to the printer (if it says 'for estimates only', slice the 3MF instead)"),
    (r"\.pages\.pdf$", "for swell paper or a braille embosser: every page of the figure, the overview first, then each panel"),
    (r"\.annotations\.png$", "a picture of what was removed from the image (burned-in scale bars, labels, data bands)"),
    (r"\.(dotpad|graphiti|monarch)-simulator\.png$", "a picture of the pin display's pages, each pin a dot (darker is higher), to look at before loading them"),
    (r"\.graphiti-(\d+)\.png$", "page \\1 of the Graphiti file as a picture, for a Graphiti that loads pictures"),
    (r"\.monarch-(\d+)\.svg$", "for the Monarch pin display: page \\1 of the plate"),
)


def file_purpose(name: str) -> str:
    """What a downloaded file is for, as a phrase ('for any slicer: the closed solid ...'): a
    format's own sentence from the format table, or one of FILE_PURPOSES."""
    from ..formats import TABLE

    for pattern, text in FILE_PURPOSES:
        found = re.search(pattern, name)
        if found:
            return found.expand(text)
    suffixes = sorted(((s, f) for f in TABLE for s in f.suffixes), key=lambda pair: -len(pair[0]))
    fmt = next((f for suffix, f in suffixes if name.lower().endswith(suffix)), None)
    if fmt is None:
        return "an output of TAMP-OS"
    return fmt.purpose[:1].lower() + fmt.purpose[1:].rstrip(".")


def readme_text(names: list[str], where: dict[str, str] | None = None) -> str:
    """README.txt for the zip: each file and what it is for (3MF to your slicer, PDF to swell paper, ...);
    a figure's files say which are the overview and which each panel (`where`: 'NAME.panel-b' -> 'top right')."""
    from .panel_choice import readme_note

    lines = ["Your tactile lithographs, made by TAMP-OS.", "", "What each file is for:", ""]
    for name in names:
        purpose = file_purpose(name)
        tile = re.search(r"\.tile-(\d+)-(\d+)\.", name)
        if tile:
            purpose += f" (tile in row {tile.group(1)} from the far edge, column {tile.group(2)} from the left)"
        purpose += readme_note(name, where or {}, names)
        lines.append(f"{name}: {purpose}.")
    lines += ["", "A 3MF file tells PrusaSlicer and OrcaSlicer the layer height the relief was designed for; in Bambu Studio "
              "choose it yourself (the description says which)."]
    return "\n".join(lines) + "\n"


def convert(job: WebJob, upload: Upload) -> Result:
    from ..lithograph.report import web_summary_lines
    from .forms import label_of, offers, web_words
    from .panel_choice import figure_prints, panel_parameter

    params = job.params.replace(preset=upload.override) if upload.override else job.params
    texts = {key: value for key, value in (("caption", upload.caption), ("subject", upload.subject)) if value}
    if texts:  # this image's own caption and subject, never another image's
        params = params.replace(**texts)
    if upload.panels and params.panels == "auto":  # this figure's own panels, as ticked on the settings page
        params = params.replace(panel=panel_parameter(upload.panels, upload.panel_choice))
    stem = Path(upload.name).stem + job.stem_suffix
    params = volume_params(params, upload)
    if params.volume:
        return _volume_result(job, upload, params, stem)
    made, failed = _in_worker(job, upload, run_library, params, stem)
    if failed is not None:
        return failed
    report, mesh = made.report, made.litho.mesh
    result = Result(
        upload.name, True, files=[OutputFile(p.name, p.stat().st_size) for p in made.all_written],
        description=" ".join([made.litho.metadata()["description"],  # a figure: the overview, then each panel
                              *(f"Panel {each.suffix[7:]}: {each.litho.metadata()['description']}" for each in made.panels)]), heightmap_png=f"{stem}.heightmap.png",
        model_glb=f"{stem}{PREVIEW_SUFFIX}", summary=web_summary_lines(report, label_of, offers),
        relief_style=report.relief_style, relief_reason=report.relief_reason, touch=[web_words(v) for v in made.touch()],
        stem=stem,
    )
    result.prints = figure_prints(made, upload.panels, lambda p: OutputFile(p.name, p.stat().st_size))
    result.figure_files = [OutputFile(p.name, p.stat().st_size) for p in made.figure_files]
    printed = {each.suffix[len(".panel-"):] for each in made.panels}
    result.left_out = [p.label for p in upload.panels if made.panels and p.label not in printed]
    write_png(job.out / result.heightmap_png, to_uint8(made.litho.heightmap))
    _render_preview(job, result, mesh, stem)
    return result
