"""The web app's routes: add images, settings, progress, results, files."""

from __future__ import annotations

import shutil

import anyio
from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, JSONResponse, RedirectResponse, Response
from starlette.exceptions import HTTPException as StarletteHTTPException

from ..errors import ParameterError, TampError
from ..formats import BY_NAME as FORMAT_TABLE
from ..params import FORMATS, LithoParams
from ..printing.printers import PRESETS
from .forms import FIELDS, FLAGS, NUMBER_FIELDS, STYLE_CHOICES, TEXT_FIELDS, params_from_form, printer_choices
from .jobs import WebJob, safe_name
from .panel_choice import choice_errors, chosen_panels, global_panel_error
from .security import only_text_fields
from .uploads import inspect_upload

MAX_TEXT_CHARS = 200  # a caption or subject per image; braille captions are a line or two
NO_TOKEN = ("Request refused", "This form is out of date or did not come from TAMP-OS. Reload the page and try again.")


def add_upload_routes(app: FastAPI, web) -> None:
    limits = web.limits

    @app.get("/")
    async def index(request: Request):
        return web.page(request, "index.html", message=request.query_params.get("message", "")[:200])

    @app.post("/jobs")
    async def upload(request: Request):
        try:
            form = await request.form(max_files=limits.max_files + 1, max_part_size=1_000_000)
        except StarletteHTTPException:  # more parts than allowed
            return upload_error(request, [f"More than {limits.max_files} files were chosen; at most {limits.max_files} "
                                          "are converted at once. Choose fewer and add the rest in another round."], 400)
        only_text_fields(form, files=("images",))
        if not web.guard.token_ok(form.get("token")):
            return web.message(403, *NO_TOKEN)
        files = [f for f in form.getlist("images") if getattr(f, "filename", "")]
        if not files:
            return upload_error(request, ["Choose at least one image file to add."], 400)
        if len(files) > limits.max_files:
            return upload_error(request, [f"{len(files)} files were chosen; at most {limits.max_files} are converted at once. "
                                          "Choose fewer and add the rest in another round."], 400)
        job = web.store.create()
        problems = await store_uploads(web, job, files)
        if problems and not job.uploads:
            web.store.remove(job.id)
            return upload_error(request, problems, 400, note="Nothing was added; choose image files and try again.")
        job.rejected = problems  # the good files stay; the settings page lists the others with their reasons
        return RedirectResponse(f"{web.base}/jobs/{job.id}", status_code=303)

    def upload_error(request, messages: list[str], status: int, note: str = ""):
        """The first page again, each problem listed once (what to do next is a note, not a problem)."""
        return web.page(request, "index.html", status=status, errors={"images": " ".join(messages + [note] * bool(note))},
                        summary=[("images", m) for m in messages], summary_note=note)


async def store_uploads(web, job: WebJob, files) -> list[str]:
    """Save and inspect each upload in a worker thread, a bounded number at a time; the problems."""
    cap, taken, problems = web.limits.max_file_mb * 1e6, set(), []
    for index, f in enumerate(files):
        name = safe_name(f.filename, taken)
        if (f.size or 0) > cap:
            problems.append(f"{name} is larger than the limit of {web.limits.max_file_mb:g} MB per file.")
            continue
        path = job.folder / "in" / name

        def save_and_inspect(f=f, path=path, name=name, index=index):
            with path.open("wb") as out:
                shutil.copyfileobj(f.file, out)
            return inspect_upload(path, name, job.thumbs, index=index, max_decoded_mb=web.limits.max_decoded_mb)

        try:
            job.uploads.append(await anyio.to_thread.run_sync(save_and_inspect, limiter=web.decode_limiter))
        except TampError as exc:
            problems.append(str(exc))
    return problems


def add_job_routes(app: FastAPI, web) -> None:
    @app.get("/jobs/{job_id}")
    async def show(request: Request, job_id: str):
        job = web.store.get(job_id)
        if job is None:
            return RedirectResponse(f"{web.base}/?message=That+job+has+ended+or+does+not+exist.", status_code=303)
        if job.state == "added":  # files refused at upload: said once, where focus lands, on the first view
            announce, job.rejected_announced = bool(job.rejected) and not job.rejected_announced, True
            return settings_page(web, request, job, focus="not-added" if announce else "")
        if job.state == "running":
            return web.page(request, "progress.html", job=job, step=3)
        return results_page(web, request, job)

    @app.post("/jobs/{job_id}/generate")
    async def generate(request: Request, job_id: str):
        job, form, refused = await _posted_job(web, request, job_id)
        if refused is not None:
            return refused
        if job.state == "running":
            return RedirectResponse(f"{web.base}/jobs/{job.id}", status_code=303)
        _take_upload_fields(job, form)
        params, errors = params_from_form(form)
        mode = params.panels if params else (form.get("panels") or "").strip().lower() or "auto"
        # Page order in the summary: the figures' checkboxes come before the customize fields.
        by_field = {**choice_errors(job.uploads, mode), **(errors.by_field if params is None else {})}
        also = (form.get("also_printer") or "").strip()
        by_field.update(_second_printer_error(also, form.get("printer")))
        by_field.update({k: v for k, v in global_panel_error(mode, (form.get("panel") or "").strip()).items() if k not in by_field})
        if by_field:
            return settings_page(web, request, job, status=400, values=form_values(job.params, form), errors=by_field)
        if form.get("action") == "update":
            params = _formats_follow_printer(job.params, params)
            job.params = params  # the page comes back with focus on the control that was used
            values = form_values(params, form)
            values["formats"] = list(params.formats)
            return settings_page(web, request, job, values=values, focus="update")
        then = (_formats_follow_printer(params, params.replace(printer=also)),) if also else ()
        web.store.start(job, params, then)  # with a second printer, the same prints again for it
        return RedirectResponse(f"{web.base}/jobs/{job.id}", status_code=303)

    @app.get("/jobs/{job_id}/status")
    async def status(job_id: str):
        job = web.store.get(job_id)
        if job is None:
            return JSONResponse({"state": "gone"}, status_code=404)
        return {"state": job.state, "done": job.done, "total": len(job.uploads), "message": job.message}

    @app.post("/jobs/{job_id}/delete")
    async def delete(request: Request, job_id: str):
        form = await request.form()
        only_text_fields(form)
        if not web.guard.token_ok(form.get("token")):
            return web.message(403, *NO_TOKEN)
        web.store.remove(job_id)
        return RedirectResponse(f"{web.base}/?message=Your+files+were+deleted.", status_code=303)


async def _posted_job(web, request: Request, job_id: str):
    """(job, form, None) for a form posted to a job, or (None, None, the response that refuses it):
    the job has ended, or the form lacks this page's token."""
    job = web.store.get(job_id)
    if job is None:
        return None, None, RedirectResponse(f"{web.base}/?message=That+job+has+ended+or+does+not+exist.", status_code=303)
    form = await request.form()
    only_text_fields(form)
    if not web.guard.token_ok(form.get("token")):
        return None, None, web.message(403, *NO_TOKEN)
    return job, form, None


def _take_upload_fields(job, form) -> None:
    """Each image's own fields (preset override, caption, subject, chosen panels) from the settings form."""
    for i, upload in enumerate(job.uploads):
        choice = form.get(f"override_{i}", "")
        upload.override = choice if choice in PRESETS else ""
        upload.caption = (form.get(f"caption_{i}") or "").strip()[:MAX_TEXT_CHARS]
        upload.subject = (form.get(f"subject_{i}") or "").strip()[:MAX_TEXT_CHARS]
        upload.panel_choice = chosen_panels(form, i, upload.panels)  # this figure's own panels


def _second_printer_error(also: str, printer: str | None) -> dict[str, str]:
    """The second printer's field error, if any: it must be one of the list and not the first printer."""
    if not also:
        return {}
    if also not in printer_choices():
        return {"also_printer": "Second printer: choose a printer from the list, or None."}
    if also == printer:
        return {"also_printer": "Second printer: choose another printer than the first, or None."}
    return {}


def add_again_route(app: FastAPI, web) -> None:
    @app.post("/jobs/{job_id}/again")
    async def again(request: Request, job_id: str):
        """The same prints for another printer: the images, captions and settings the job has."""
        job, form, refused = await _posted_job(web, request, job_id)
        if refused is not None:
            return refused
        if job.state != "done":
            return RedirectResponse(f"{web.base}/jobs/{job.id}", status_code=303)
        printer = form.get("printer") or ""
        made = {job.params.printer, *(run.printer for run in job.earlier)}
        if printer not in printer_choices() or printer in made:
            error = ("Printer for the next round: choose a printer from the list." if printer not in printer_choices()
                     else f"Printer for the next round: the prints for {printer} are already on this page; choose another printer.")
            return results_page(web, request, job, status=400, errors={"again-printer": error})
        web.store.again(job, _formats_follow_printer(job.params, job.params.replace(printer=printer)))
        return RedirectResponse(f"{web.base}/jobs/{job.id}", status_code=303)


CHOICE_FIELDS = ("braille_table", "page_size")  # chosen from a list (forms.py checks the value)


def _suited(params: LithoParams):
    from ..printing.printers import get_printer
    from ..printing.suited import suited_outputs

    try:
        layer_mm = get_printer(params.printer).layer_mm
    except ParameterError:  # the form says what is wrong with the printer; no advice on its outputs
        return suited_outputs("standard", params.layer_mm or 0.12)
    return suited_outputs(params.printer, layer_mm)


def _formats_follow_printer(before: LithoParams, after: LithoParams) -> LithoParams:
    """A new printer brings its own default outputs (the 3MF for a slicer that reads its settings),
    unless the user chose other outputs than the old printer's defaults: those stay."""
    if after.printer == before.printer or set(after.formats) != set(_suited(before).formats):
        return after
    return after.replace(formats=_suited(after).formats)


def form_values(params: LithoParams, form=None) -> dict:
    """The settings form's values: from the parameters, or as the user typed them."""
    values = {name: "" if getattr(params, name) is None else getattr(params, name) for name in (*TEXT_FIELDS, *NUMBER_FIELDS)}
    values.update({name: getattr(params, name) for name in FLAGS})
    values["printer"], values["preset"], values["formats"] = params.printer, params.preset, list(params.formats)
    values["relief_style"] = params.relief_style
    values.update({name: getattr(params, name) for name in CHOICE_FIELDS})
    if form is not None:
        for key in (*TEXT_FIELDS, *NUMBER_FIELDS, *CHOICE_FIELDS, "printer", "also_printer", "preset", "relief_style"):
            values[key] = form.get(key, "")
        values.update({key: form.get(key) == "on" for key in FLAGS})
        values["formats"] = form.getlist("formats")
    return values


def settings_page(web, request, job: WebJob, *, status: int = 200, values=None, errors=None, focus: str = ""):
    from .cards import detail_cards
    from .forms import braille_table_choices

    errors = errors or {}
    return web.page(
        request, "settings.html", status=status, job=job, step=2, values=values or form_values(job.params), errors=errors,
        summary=list(errors.items()), cards=detail_cards(job, job.params), printers=printer_choices(), presets=list(PRESETS),
        formats=FORMATS, format_table=FORMAT_TABLE, fields=FIELDS, styles=STYLE_CHOICES, customize_open=bool(set(errors) & set(FIELDS)) or request.query_params.get("customize") == "open",
        braille_tables=braille_table_choices(), page_sizes=PAGE_SIZES, focus=focus, printer_outputs=_suited(job.params).words,
        multi_channel=any(u.channels > 1 for u in job.uploads), z_stack=any(u.z_slices > 1 for u in job.uploads),
        time_series=any(u.time_points > 1 for u in job.uploads), scenes=any(u.scenes > 1 for u in job.uploads),
    )


def results_page(web, request, job: WebJob, *, status: int = 200, errors=None):
    errors = errors or {}
    made = {job.params.printer, *(run.printer for run in job.earlier)}
    others = {name: p for name, p in printer_choices().items() if name not in made}
    return web.page(request, "results.html", status=status, job=job, step=3, errors=errors, summary=list(errors.items()),
                    other_printers=others)


PAGE_SIZES = (("plate", "The plate's own size"), ("a4", "A4, centred"), ("letter", "US Letter, centred"))


def add_file_routes(app: FastAPI, web) -> None:
    def missing():
        return Response("No such file in this job.", status_code=404, media_type="text/plain")

    @app.get("/jobs/{job_id}/files/{name}")
    async def download(job_id: str, name: str):
        job = web.store.get(job_id)
        if job is None or name not in job.output_names():
            return missing()
        return FileResponse(job.out / name, filename=name)

    @app.get("/jobs/{job_id}/thumbs/{name}")
    async def thumb(job_id: str, name: str):
        job = web.store.get(job_id)
        if job is None or name not in {u.thumb for u in job.uploads} | {p.thumb for u in job.uploads for p in u.panels}:
            return missing()
        return FileResponse(job.thumbs / name, media_type="image/png")

    @app.get("/jobs/{job_id}/download.zip")
    async def download_zip(job_id: str):
        job = web.store.get(job_id)
        if job is None or job.state != "done":
            return Response("No finished job with that id.", status_code=404, media_type="text/plain")
        headers = {"Content-Disposition": 'attachment; filename="tamp-os-lithographs.zip"'}
        data = await anyio.to_thread.run_sync(web.store.zip_bytes, job)
        return Response(data, media_type="application/zip", headers=headers)
