import ctypes
import functools
import os
import shutil
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

ROOT = Path(__file__).resolve().parents[1]
# TAMP_FIXTURES: for runs from a copy of the tree (mutation testing runs the tests from mutants/).
FIXTURES = Path(os.environ.get("TAMP_FIXTURES") or ROOT.parent / "shared" / "fixtures")
STRICT = os.environ.get("TAMP_STRICT") == "1"
# Offscreen rendering for tests that render in this process (the CLI and web app set it themselves).
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

# Hypothesis profiles: `ci` keeps each test's own example count (`make test`, CI), `dev` runs a
# tenth of them (`make test-fast`). Tests write `max_examples=examples(N)`. The `ci` profile is
# derandomised (the same examples on every run, so CI passes or fails the same way twice); `dev`
# draws new ones each run, and prints the seed of a failure to reproduce it.
HYPOTHESIS_PROFILE = os.environ.get("TAMP_HYPOTHESIS", "ci")
settings.register_profile("ci", deadline=None, derandomize=True, database=None)
settings.register_profile("dev", deadline=None, max_examples=10)
settings.load_profile(HYPOTHESIS_PROFILE if HYPOTHESIS_PROFILE in ("ci", "dev") else "ci")


def examples(n: int) -> int:
    """A test's hypothesis example count under the current profile."""
    return n if HYPOTHESIS_PROFILE != "dev" else max(2, n // 10)


# Test tiers, applied from what a test uses, so that no one has to remember to mark it:
# `browser` (headless Chromium), `slicer` (PrusaSlicer), `real` (the real microscope files in
# ../shared/fixtures), `napari` (a napari viewer, headless: tests/napari/conftest.py); `slow` for a test of the web app's real server (fixtures `server`, `slow_server`, `patient_server`), and by
# hand on the few synthetic tests that take more than about 5 s.
# `make test-fast` leaves all five out; `make test` and CI run everything.
TIER_BY_FIXTURE = {"browser": "browser", "slicer_present": "slicer", "fixture": "real", "fixtures_dir": "real", "server": "slow", "slow_server": "slow", "patient_server": "slow",
                   "napari_viewer": "napari", "napari_plugin": "napari"}


def pytest_collection_modifyitems(config, items):
    for item in items:
        tiers = {TIER_BY_FIXTURE[name] for name in getattr(item, "fixturenames", ()) if name in TIER_BY_FIXTURE}
        params = getattr(getattr(item, "callspec", None), "params", {})
        if any(isinstance(v, str) and v and (FIXTURES / v).is_file() for v in params.values()):
            tiers.add("real")  # parametrized by a fixture file's name
        for tier in sorted(tiers):
            item.add_marker(getattr(pytest.mark, tier))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """A test whose set-up skipped or failed never runs, so it has no call report; napari's
    make_napari_viewer reads `item.rep_call` at teardown, and without one it errors
    (AttributeError) after a clean skip. The set-up's report stands in for it."""
    outcome = yield
    report = outcome.get_result()
    if report.when == "setup" and not report.passed and not hasattr(item, "rep_call"):
        item.rep_call = report


def pytest_terminal_summary(terminalreporter):
    """Say how many tests skipped because the shared fixtures are missing (a clone without ../shared)."""
    missing = [r for r in terminalreporter.stats.get("skipped", []) if "fixture" in str(r.longrepr)]
    if missing and not FIXTURES.is_dir():
        terminalreporter.write_line(f"{len(missing)} tests skipped: the fixtures folder {FIXTURES} is missing")


def run_cli(capsys, *argv) -> tuple[int, str, str]:
    """Run the tamp-os command line in this process: (exit code, stdout, stderr)."""
    from tamp_os.cli.commands import main

    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def need(condition: bool, what: str) -> None:
    """Skip when a tool or file is missing; under TAMP_STRICT=1 (CI) fail instead."""
    if not condition:
        if STRICT:
            pytest.fail(f"TAMP_STRICT=1 and {what} is missing")
        pytest.skip(f"{what} is missing")


def need_module(name: str):
    """Import a module a test needs; skip when it is missing, or under TAMP_STRICT=1 fail."""
    import importlib

    try:
        return importlib.import_module(name)
    except ImportError:
        need(False, f"the Python module {name}")


@pytest.fixture
def fixtures_dir() -> Path:
    need(FIXTURES.is_dir(), f"the fixtures folder {FIXTURES}")
    return FIXTURES


@pytest.fixture
def fixture(fixtures_dir):
    def get(name: str) -> Path:
        path = fixtures_dir / name
        need(path.is_file(), f"fixture {name}")
        return path

    return get


def spy_atomic_writes(monkeypatch, *modules) -> list[str]:
    """Record the name of every file written through export.files.write_atomic, as `modules` (which
    imported it by name) and the files module itself call it: the list fills as files are written."""
    from tamp_os.export import files

    calls: list[str] = []
    real = files.write_atomic

    def spy(path, write):
        calls.append(Path(path).name)
        return real(path, write)

    for module in (*modules, files):
        monkeypatch.setattr(module, "write_atomic", spy)
    return calls


def node_validator() -> Path | None:
    script = ROOT / ".tools" / "node_modules" / "gltf-validator"
    return script if script.is_dir() and shutil.which("node") else None


@pytest.fixture
def gradient_image():
    """An asymmetric test picture: a horizontal ramp plus a bright block at the top left."""
    img = np.tile(np.linspace(0, 200, 64, dtype=np.float32), (48, 1))
    img[4:16, 4:20] = 255
    return img.astype(np.uint8)


# napari's pytest plugin (loaded whenever napari is installed) has two autouse fixtures that import
# napari's Qt window and themes for every test: 10-15 s at the start of each test process here. These
# names override them for the whole suite; tests/napari_support.py does their work for the napari tier.
@pytest.fixture
def _disable_qt_warnings():
    return None


@pytest.fixture
def _clean_themes():
    return None


@pytest.fixture(autouse=True)
def _locale_kept():
    """lib3mf (the independent 3MF reader of many tests) sets the process's locale to "C" and leaves
    it so, which turns Python's default text encoding into ASCII for every later test in the worker
    (a child's UTF-8 output then fails to decode). Each test gets the locale it started with back."""
    import locale

    saved = locale.setlocale(locale.LC_ALL)
    yield
    if locale.setlocale(locale.LC_ALL) != saved:
        locale.setlocale(locale.LC_ALL, saved)


# Signals whose handling a library must not change in a test worker: Python ignores SIGPIPE (a
# write to a closed pipe or socket is then an error, not the end of the process) and the fault
# handler prints a traceback on the others. gmsh.initialize() once reset all but SIGABRT from C:
# later a write to a closed socket ended the worker silently, and pytest-xdist waited forever.
WATCHED_SIGNALS = ("SIGPIPE", "SIGSEGV", "SIGFPE", "SIGBUS", "SIGILL", "SIGABRT")


class _SigAction(ctypes.Structure):  # Linux's struct sigaction: the handler comes first
    _fields_ = [("handler", ctypes.c_void_p), ("mask", ctypes.c_ulong * 16), ("flags", ctypes.c_int),
                ("restorer", ctypes.c_void_p)]


@functools.cache
def _libc() -> ctypes.CDLL:
    return ctypes.CDLL(None, use_errno=True)


def _sigactions() -> dict[str, _SigAction]:
    """The process's own (C-level) handlers: signal.getsignal only knows what Python set."""
    actions = {}
    for name in WATCHED_SIGNALS:
        actions[name] = _SigAction()
        _libc().sigaction(getattr(signal, name), None, ctypes.byref(actions[name]))
    return actions


@pytest.fixture(autouse=True)
def _signals_kept():
    """A test that leaves the worker's signal handling changed fails, and the handlers are put back."""
    if not sys.platform.startswith("linux"):
        yield
        return
    before = _sigactions()
    yield
    changed = [name for name, action in _sigactions().items() if action.handler != before[name].handler]
    for name in changed:
        _libc().sigaction(getattr(signal, name), ctypes.byref(before[name]), None)
    assert not changed, f"the test changed this process's handling of {', '.join(changed)} (a library reset it from C); run that library in a child process"
