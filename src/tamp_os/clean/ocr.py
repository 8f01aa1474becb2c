"""Short texts (panel letters) read by Tesseract, in this process when it can be.

Why tesserocr (the in-process libtesseract API) first: a `tesseract` command spends 0.4-0.6 s
starting and loading its model for every call, against 25-40 ms for a read through tesserocr,
whose model loads once per process (0.2-0.5 s) and then stays (benchmarks/bench_panels.py
measures both). Loading it in a background thread while the gutters are searched was measured
and dropped: the first figure of a process took 0.43-0.82 s so (median 0.53) against 0.23-0.69 s
(median 0.38) loading it when first needed, on the 2 shared cores (the two compete for them, and
the gutter search, now 80 ms, leaves little to hide the load behind). Its manylinux wheel bundles libtesseract, so nothing is built; the model files come from the system's
tesseract-ocr-eng package, the same that the command reads. The command line is the fallback
only when tesserocr or a model for it is missing.
"""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import tempfile
import threading
import time
from pathlib import Path

log = logging.getLogger(__name__)

# Where Debian's and other distributions' tesseract-ocr-eng put the models (the wheel knows no default).
TESSDATA_DIRS = ("/usr/share/tesseract-ocr/5/tessdata", "/usr/share/tesseract-ocr/4.00/tessdata", "/usr/share/tessdata",
                 "/usr/local/share/tessdata", "/usr/local/share/tesseract-ocr/tessdata", "/opt/homebrew/share/tessdata")
LANGUAGE = "eng"

_lock = threading.Lock()  # one API object, used by one thread at a time (libtesseract is not reentrant)
_state: dict[str, object] = {}  # "api": the loaded API and "seconds" its load, or "failed": why it could not load


def _after_fork() -> None:
    """A forked child (batch workers) starts afresh: the parent's lock may have been held, or its
    load half done, by a thread the child does not have."""
    global _lock
    _lock = threading.Lock()
    _state.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork)


def tessdata_dir() -> Path | None:
    """The folder holding LANGUAGE.traineddata: TESSDATA_PREFIX when set, else the usual places."""
    prefix = os.environ.get("TESSDATA_PREFIX")
    for folder in ([prefix, str(Path(prefix) / "tessdata")] if prefix else []) + list(TESSDATA_DIRS):
        if (Path(folder) / f"{LANGUAGE}.traineddata").is_file():
            return Path(folder)
    return None


def backend() -> str | None:
    """'tesserocr' (in process), 'command' (the tesseract program) or None (no OCR here)."""
    if _api() is not None:
        return "tesserocr"
    return "command" if shutil.which("tesseract") else None


def _api():
    """The process's tesserocr API (loaded on first use), or None when it cannot be had."""
    if "api" in _state:
        return _state["api"]
    if "failed" in _state:
        return None
    with _lock:
        if not _state:
            _state.update(_load())
    return _state.get("api")


def _load() -> dict[str, object]:
    try:
        import tesserocr
    except ImportError:
        return {"failed": "the tesserocr module is not installed"}
    folder = tessdata_dir()
    if folder is None:
        return {"failed": f"no {LANGUAGE}.traineddata found (apt-get install tesseract-ocr-eng)"}
    start = time.perf_counter()
    try:
        # LSTM only: the one engine the packaged models always carry (Debian's eng has no legacy model).
        api = tesserocr.PyTessBaseAPI(path=str(folder) + os.sep, lang=LANGUAGE, oem=tesserocr.OEM.LSTM_ONLY)
    except RuntimeError as error:
        return {"failed": f"tesserocr could not load the {LANGUAGE} model in {folder}: {error}"}
    log.debug("OCR in process: tesserocr %s, model in %s", tesserocr.tesseract_version().splitlines()[0], folder)
    return {"api": api, "seconds": time.perf_counter() - start}


def read_text(image, psm: int, whitelist: str) -> str | None:
    """The text Tesseract reads on a PIL image in page segmentation mode `psm` (6: a block of
    lines, 10: one character), only characters of `whitelist`; None when OCR failed or is missing."""
    api = _api()
    if api is not None:
        with _lock:
            api.SetPageSegMode(psm)
            api.SetVariable("tessedit_char_whitelist", whitelist)
            api.SetImage(image)
            text = api.GetUTF8Text()
            api.Clear()
        return text
    return _command(image, psm, whitelist)


def read_line(image) -> tuple[str, float] | None:
    """One line of text on a PIL image (page segmentation mode 7, any character) and Tesseract's
    mean word confidence, 0-100; None when OCR is missing or failed."""
    api = _api()
    if api is not None:
        with _lock:
            api.SetPageSegMode(7)
            api.SetVariable("tessedit_char_whitelist", "")
            api.SetImage(image)
            text = api.GetUTF8Text()
            confidence = float(api.MeanTextConf())
            api.Clear()
        return text.strip(), confidence
    tsv = _command(image, 7, "", "tsv")
    if tsv is None:
        return None
    words, confidences = [], []
    for row in tsv.splitlines()[1:]:  # level page block par line word left top width height conf text
        cells = row.split("\t")
        if len(cells) == 12 and cells[0] == "5" and cells[11].strip():
            words.append(cells[11].strip())
            confidences.append(float(cells[10]))
    return " ".join(words), (sum(confidences) / len(confidences) if confidences else 0.0)


def _command(image, psm: int, whitelist: str, output: str = "") -> str | None:
    exe = shutil.which("tesseract")
    if exe is None:
        return None
    with tempfile.TemporaryDirectory(prefix="tamp-ocr-") as tmp:
        path = Path(tmp) / "text.png"
        image.save(path)
        command = [exe, str(path), "stdout", "--psm", str(psm), "-l", LANGUAGE, "-c", f"tessedit_char_whitelist={whitelist}"]
        command += [output] if output else []
        # One thread: Tesseract's OpenMP threads slow a page this small down, most on a busy machine.
        env = {**os.environ, "OMP_THREAD_LIMIT": "1"}
        try:
            done = subprocess.run(command, capture_output=True, text=True, encoding="utf-8", errors="replace", timeout=60, env=env)
        except (OSError, subprocess.TimeoutExpired):
            return None
    return done.stdout if done.returncode == 0 else None
