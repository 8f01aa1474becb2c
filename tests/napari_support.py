"""Fixtures and helpers of the napari plugin's tests (tests/napari/), which run headless: Qt's
offscreen platform, drawing with OpenGL through an X display. Where none is set (CI, a terminal
over ssh) an Xvfb server is started, which ends with the test process. `napari_viewer` is the
tier's fixture (conftest.TIER_BY_FIXTURE): a viewer, or a skip (under TAMP_STRICT=1 a failure)
when napari is missing."""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest

from conftest import need, need_module


def _die_with_parent() -> None:
    """In the Xvfb child: end when the test process ends (Linux's parent-death signal)."""
    import ctypes
    import signal

    ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


@pytest.fixture(scope="session")
def headless_display():
    """DISPLAY for the session: the one set, else an Xvfb server of our own. The server outlives the
    session and ends with the test process: Qt keeps its connection until the process exits, and
    an X server gone before then makes Qt end the process with a failure."""
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    if not os.environ.get("DISPLAY"):
        xvfb = shutil.which("Xvfb")
        need(xvfb is not None, "Xvfb (Debian package xvfb), which napari's OpenGL canvas needs without a screen")
        read, write = os.pipe()
        subprocess.Popen([xvfb, "-displayfd", str(write), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                         pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=_die_with_parent)
        os.close(write)
        with os.fdopen(read) as fh:
            number = fh.readline().strip()  # Xvfb writes its display number once it accepts clients
        need(number.isdigit(), "a running Xvfb display")
        os.environ["DISPLAY"] = f":{number}"
    return os.environ["DISPLAY"]


@pytest.fixture
def napari_viewer(headless_display, request):
    """A napari viewer (napari's make_napari_viewer fixture), or a skip/strict failure without napari."""
    need_module("napari.viewer")  # not just `napari`: without it, tests/napari would pass for the package
    need_module("magicgui")
    if "fixtures_dir" in request.fixturenames:  # a test of a real file skips before a viewer is made for it
        request.getfixturevalue("fixtures_dir")
    from napari._qt import qt_main_window

    # what napari's autouse fixture does (tests/conftest.py overrides it for the rest of the suite)
    request.getfixturevalue("monkeypatch").setattr(qt_main_window, "SHOW_QT_WARNING", False)
    make = request.getfixturevalue("make_napari_viewer")
    _ask_opengl_once(request.getfixturevalue("qtbot"))
    return make()


def _ask_opengl_once(qtbot) -> None:
    """napari asks OpenGL for its extensions and texture sizes once per process (and keeps the
    answers); asked while no context is current, the answer is empty and napari fails to add a
    layer. Ask here, with a context of its own, until it answers."""
    from napari._vispy.utils.gl import get_gl_extensions, get_max_texture_sizes

    for _ in range(5):
        if get_gl_extensions() and all(get_max_texture_sizes()):
            return
        get_gl_extensions.cache_clear()
        get_max_texture_sizes.cache_clear()
        qtbot.wait(100)
    need(False, f"an OpenGL context on the X display {os.environ.get('DISPLAY')}")


@pytest.fixture
def print_widget(napari_viewer, tmp_path):
    """The plugin's dock widget in the viewer, writing to tmp_path/prints."""
    from tamp_os.napari.widget import PrintWidget

    widget = PrintWidget(napari_viewer)
    napari_viewer.window.add_dock_widget(widget, name="Make a tactile print")
    widget.output.value = tmp_path / "prints"
    return widget


@pytest.fixture
def napari_plugin():
    """The plugin's libraries (napari, magicgui, npe2), or a skip/strict failure; no viewer."""
    for name in ("napari.viewer", "magicgui", "npe2"):
        need_module(name)
    from pathlib import Path

    from tamp_os.napari import __file__ as package

    return Path(package).parent / "napari.yaml"


def make_and_wait(widget, qtbot, timeout_ms: int = 240_000):
    """Press "Make print" as a user does and wait until the worker has finished."""
    widget.make.native.click()
    qtbot.waitUntil(lambda: widget.make.enabled, timeout=timeout_ms)
