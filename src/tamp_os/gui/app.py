"""The web app: a FastAPI server with Jinja2 pages that work without JavaScript.

Flow: add images -> choose printer, detail (Low/Medium/High cards, with the suggestion and an
override per image), customize, formats -> Generate -> progress -> results with previews (alt
text), report and downloads. Safety: upload size and count capped, names sanitized, each job in
its own folder, files served only by name from the job's own output list.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, RedirectResponse, Response
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates

from ..errors import ParameterError, TampError
from ..params import FORMATS, LithoParams, parse_field
from ..printers import PRESETS, all_printers, get_printer
from .jobs import JobStore, Upload, safe_name

HERE = Path(__file__).parent
TEXT_FIELDS = ("caption", "pixel_size", "scale_bar")
NUMBER_FIELDS = ("width_mm", "height_mm", "nozzle_mm", "layer_mm", "relief_mm", "base_mm", "blur_px", "resolution_px", "frame_mm")
FLAGS = ("invert", "flip_x", "keep_annotations", "gcode")


@dataclasses.dataclass
class Limits:
    max_file_mb: float = 50.0
    max_files: int = 20


def create_app(limits: Limits | None = None, store: JobStore | None = None) -> FastAPI:
    limits = limits or Limits()
    if store is None:
        # Operational knobs (the tests use them): where job folders live, how long a job is kept
        # after its zip is downloaded, and an artificial delay per image to observe progress.
        env = os.environ
        store = JobStore(
            root=env.get("TAMP_GUI_ROOT") or None,
            grace_s=float(env.get("TAMP_GUI_GRACE_S", 60)),
            slow_s=float(env.get("TAMP_GUI_SLOW_S", 0)),
        )

    @contextlib.asynccontextmanager
    async def lifespan(app):
        yield
        store.close()  # the job folders go with the server

    app = FastAPI(title="TAMP-OS", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.state.store = store
    app.mount("/static", StaticFiles(directory=HERE / "static"), name="static")
    templates = Jinja2Templates(directory=HERE / "templates")

    @app.middleware("http")
    async def headers(request: Request, call_next):
        response = await call_next(request)
        response.headers["X-Content-Type-Options"] = "nosniff"
        response.headers["Content-Security-Policy"] = "default-src 'self'; img-src 'self' data:; style-src 'self'; script-src 'self'"
        response.headers["Referrer-Policy"] = "no-referrer"
        return response

    def page(request, name, status=200, **context):
        context.setdefault("errors", {})
        context.setdefault("summary", [])
        return templates.TemplateResponse(request, name, {"limits": limits, **context}, status_code=status)

    @app.get("/", response_class=HTMLResponse)
    async def index(request: Request):
        return page(request, "index.html", message=request.query_params.get("message", "")[:200])

    @app.post("/jobs")
    async def upload(request: Request):
        cap = limits.max_file_mb * 1e6
        length = int(request.headers.get("content-length") or 0)
        if length > cap * limits.max_files + 1e6:
            return _upload_error(request, f"The upload is {length / 1e6:.0f} MB; at most {limits.max_files} images of "
                                          f"{limits.max_file_mb:g} MB each are accepted. Choose fewer or smaller files.", 413)
        form = await request.form(max_files=limits.max_files + 1, max_part_size=int(cap) + 1)
        files = [f for f in form.getlist("images") if getattr(f, "filename", "")]
        if not files:
            return _upload_error(request, "Choose at least one image file to add.", 400)
        if len(files) > limits.max_files:
            return _upload_error(request, f"{len(files)} files chosen; at most {limits.max_files} per job. Choose fewer.", 400)
        job = store.create()
        taken: set[str] = set()
        problems = []
        for f in files:
            name = safe_name(f.filename, taken)
            data = await f.read(int(cap) + 1)
            if len(data) > cap:
                problems.append(f"{name}: the file is larger than the limit of {limits.max_file_mb:g} MB.")
                continue
            path = job.folder / "in" / name
            path.write_bytes(data)
            try:
                job.uploads.append(_inspect(path, name))
            except TampError as exc:
                problems.append(str(exc).replace(str(path), name))
        if problems:
            store.remove(job.id)
            return _upload_error(request, " ".join(problems) + " Nothing was added; choose image files and try again.", 400)
        return RedirectResponse(f"/jobs/{job.id}", status_code=303)

    def _upload_error(request, message, status):
        return page(request, "index.html", status=status, errors={"images": message}, summary=[("images", message)])

    def _job_or_404(job_id):
        job = store.get(job_id)
        if job is None:
            return None, RedirectResponse("/?message=That+job+has+ended+or+does+not+exist.", status_code=303)
        return job, None

    def _form_values(job, form=None, params=None):
        params = params or job.params
        values = {name: "" if getattr(params, name) is None else getattr(params, name) for name in (*TEXT_FIELDS, *NUMBER_FIELDS)}
        values.update({name: getattr(params, name) for name in FLAGS})
        values["printer"], values["preset"], values["formats"] = params.printer, params.preset, list(params.formats)
        if form is not None:
            for key in (*TEXT_FIELDS, *NUMBER_FIELDS, "printer", "preset"):
                values[key] = form.get(key, "")
            for key in FLAGS:
                values[key] = form.get(key) == "on"
            values["formats"] = form.getlist("formats")
        return values

    def _cards(job, params):
        from ..preset_table import preset_rows

        first = job.uploads[0]
        try:
            return preset_rows(params, first.width, first.height)
        except TampError:
            return preset_rows(LithoParams(printer=params.printer), first.width, first.height)

    def _job_page(request, job, status=200, values=None, errors=None, summary=None, params=None):
        params = params or job.params
        return page(
            request, "job.html", status=status, job=job, values=values or _form_values(job), errors=errors or {},
            summary=summary or [], cards=_cards(job, params), printers=all_printers(), presets=list(PRESETS), formats=FORMATS,
            customize_open=bool(errors) or request.query_params.get("customize") == "open",
        )

    @app.get("/jobs/{job_id}", response_class=HTMLResponse)
    async def show(request: Request, job_id: str):
        job, redirect = _job_or_404(job_id)
        return redirect or _job_page(request, job)

    @app.post("/jobs/{job_id}/generate")
    async def generate(request: Request, job_id: str):
        job, redirect = _job_or_404(job_id)
        if redirect:
            return redirect
        if job.state == "running":
            return RedirectResponse(f"/jobs/{job.id}", status_code=303)
        form = await request.form()
        values = _form_values(job, form)
        try:
            params = _params(form)
        except ParameterError as exc:
            field = str(exc).split(":", 1)[0].strip()
            field = field if field in values else "general"
            return _job_page(request, job, 400, values, {field: str(exc)}, [(field, str(exc))])
        for i, upload in enumerate(job.uploads):
            choice = form.get(f"override_{i}", "")
            upload.override = choice if choice in PRESETS else ""
        if form.get("action") == "update":
            job.params = params
            return _job_page(request, job, values=values, params=params)
        store.start(job, params)
        return RedirectResponse(f"/jobs/{job.id}", status_code=303)

    def _params(form) -> LithoParams:
        changes = {name: parse_field(name, form.get(name) or "") for name in (*NUMBER_FIELDS, *TEXT_FIELDS) if (form.get(name) or "").strip()}
        changes.update({name: form.get(name) == "on" for name in FLAGS})
        changes["printer"] = form.get("printer") or "standard"
        changes["preset"] = form.get("preset") or "medium"
        changes["formats"] = tuple(form.getlist("formats")) or ("stl",)
        params = LithoParams(**changes)
        get_printer(params.printer)
        return params

    @app.get("/jobs/{job_id}/status")
    async def status(job_id: str):
        job = store.get(job_id)
        if job is None:
            return JSONResponse({"state": "gone"}, status_code=404)
        return {"state": job.state, "done": job.done, "total": len(job.uploads), "message": job.message}

    @app.get("/jobs/{job_id}/files/{name}")
    async def download(job_id: str, name: str):
        job = store.get(job_id)
        if job is None or name not in job.output_names():
            return Response("No such file in this job.", status_code=404, media_type="text/plain")
        return FileResponse(job.out / name, filename=name)

    @app.get("/jobs/{job_id}/download.zip")
    async def download_zip(job_id: str):
        job = store.get(job_id)
        if job is None or job.state != "done":
            return Response("No finished job with that id.", status_code=404, media_type="text/plain")
        headers = {"Content-Disposition": 'attachment; filename="tamp-os-lithographs.zip"'}
        return Response(store.zip_bytes(job), media_type="application/zip", headers=headers)

    @app.post("/jobs/{job_id}/delete")
    async def delete(job_id: str):
        store.remove(job_id)
        return RedirectResponse("/?message=Your+files+were+deleted.", status_code=303)

    return app


def _inspect(path: Path, name: str) -> Upload:
    """Read an upload once: refuse non-images, and suggest a preset from its contrast and detail."""
    from ..relief.suggest import image_stats, suggest_preset
    from ..read import read_image

    picture = read_image(path)
    preset, reason = suggest_preset(image_stats(picture.values, picture.alpha))
    return Upload(name, path, picture.file.width, picture.file.height, preset, reason)
