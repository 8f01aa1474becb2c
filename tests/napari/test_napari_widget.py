"""The dock widget in a headless napari viewer: it prints what `tamp-os convert` prints from the
same file with the same settings (byte for byte), adds the relief and the mesh back in mm, keeps
the viewer responsive while it works, and says a bad layer in one sentence naming its control."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from conftest import run_cli
from napari_support import headless_display, make_and_wait, napari_viewer, print_widget  # noqa: F401

SETTINGS = ["--preset", "low", "--caption", "FePt", "--formats", "stl,3mf"]


def set_controls(widget, *, caption: str = "FePt") -> None:
    widget.preset.value = "low"
    widget.caption.value = caption
    widget.formats.value = ("stl", "3mf")


def same_files(cli_dir, widget_dir, stem: str) -> None:
    for suffix in (".stl", ".3mf"):
        cli, made = (cli_dir / f"{stem}{suffix}").read_bytes(), (widget_dir / f"{stem}{suffix}").read_bytes()
        assert made == cli, f"{stem}{suffix}: the widget's file differs from tamp-os convert's"


@pytest.mark.timeout(600)
def test_fept_prints_as_the_command_line_does_off_the_viewer_thread(print_widget, napari_viewer, fixture, tmp_path, capsys, qtbot):
    from qtpy.QtCore import QTimer

    png = fixture("fept_spheres_sem.png")
    code, _, err = run_cli(capsys, "convert", png, "-o", tmp_path / "cli", *SETTINGS)
    assert code == 0, err
    layer = napari_viewer.open(str(png))[0]  # napari's own PNG reader: the layer knows its file
    napari_viewer.layers.selection = {layer}
    assert print_widget.layers.value == [layer]  # the widget follows the viewer's selection
    set_controls(print_widget)
    ticks, threads, heard = [], set(), []
    timer = QTimer()
    timer.timeout.connect(lambda: ticks.append(1))
    real = print_widget._heard

    def heard_on(stage):  # the listener runs where convert() runs
        threads.add(threading.get_ident())
        heard.append((stage, len(ticks)))
        real(stage)

    print_widget._heard = heard_on
    timer.start(5)
    make_and_wait(print_widget, qtbot)
    timer.stop()
    assert print_widget.conversion is not None, print_widget.message.value
    assert threads and threading.get_ident() not in threads  # convert() ran off the viewer's thread
    stages = [s for s, _ in heard]
    assert stages[0] == "read" and stages[-1] == "save"
    # the viewer's event loop kept running while convert() worked: the timer fired between its stages
    assert heard[-1][1] - heard[0][1] >= 3, heard
    assert print_widget.progress.value == print_widget.progress.max
    same_files(tmp_path / "cli", tmp_path / "prints", "fept_spheres_sem")

    litho = print_widget.conversion.litho
    relief = napari_viewer.layers["fept_spheres_sem relief (mm)"]
    assert relief.data.shape == litho.heightmap.shape
    assert np.allclose(relief.scale, litho.layout.mm_per_px) and all(str(u) == "millimeter" for u in relief.units)
    assert float(relief.data.max()) == pytest.approx(float(litho.heightmap.max()))
    mesh = napari_viewer.layers["fept_spheres_sem mesh (mm)"]
    assert len(mesh.data[1]) == litho.mesh.n_triangles
    # the mesh's far edge (largest y) is the picture's top row (row 0), as napari shows it
    far = litho.mesh.vertices[:, 1].argmax()
    assert mesh.data[0][far, 1] == pytest.approx(0.0)
    text = (tmp_path / "prints" / "fept_spheres_sem.description.txt").read_text(encoding="utf-8").strip()
    assert text in print_widget.description.value
    assert "fept_spheres_sem.png" in print_widget.description.value.splitlines()[0]
    message = print_widget.message.value
    assert message.startswith("fept_spheres_sem.png: ") and "Traceback" not in message  # the name as on the disk
    assert "its description and recipe. The files are in " in message and message.endswith(".")
    assert print_widget.layers.value == [layer]  # the picture stays chosen, not the relief napari selected when adding it


@pytest.mark.timeout(600)
def test_two_channel_czi_prints_as_the_command_line_does(print_widget, napari_viewer, fixture, tmp_path, capsys, qtbot):
    from tamp_os.napari.reader import read_layers

    czi = fixture("real/zeiss_dapi_gfp_2ch.czi")
    code, _, err = run_cli(capsys, "convert", czi, "-o", tmp_path / "cli", *SETTINGS)
    assert code == 0, err
    layers = [napari_viewer.add_image(data, **keywords) for data, keywords, _ in read_layers(czi)]
    assert len(layers) == 2
    napari_viewer.layers.selection = set(layers)
    set_controls(print_widget)
    make_and_wait(print_widget, qtbot)
    made = print_widget.conversion
    assert made is not None, print_widget.message.value
    same_files(tmp_path / "cli", tmp_path / "prints", "zeiss_dapi_gfp_2ch")
    assert len(made.report.key) == 2  # one plate: a texture per channel, named in the braille key
    assert "key" in print_widget.description.value
    # the widget has no channel controls: no advice naming them, in the description or beside it (issue 54.7)
    assert "channel by channel" in print_widget.description.value
    assert not [w for w in ("prints a single channel", "channels off", "`", "⟦") if w in print_widget.description.value]


@pytest.mark.timeout(600)
def test_channel_layers_without_a_file_print_as_one_plate_with_a_key(print_widget, napari_viewer, tmp_path, qtbot):
    yy, xx = np.mgrid[0:160, 0:200]
    nuclei = np.zeros((160, 200), np.float32)
    for y, x in [(40, 50), (110, 140), (60, 150)]:
        nuclei[(yy - y) ** 2 + (xx - x) ** 2 < 14 ** 2] = 200
    lines = ((np.abs((xx - yy) % 40 - 20) < 2) * 180).astype(np.float32)
    one = napari_viewer.add_image(nuclei, name="DAPI", scale=(0.2, 0.2), units=("micrometer", "micrometer"))
    two = napari_viewer.add_image(lines, name="phalloidin", scale=(0.2, 0.2), units=("micrometer", "micrometer"))
    napari_viewer.layers.selection = {one, two}
    print_widget.preset.value = "low"
    make_and_wait(print_widget, qtbot)
    made = print_widget.conversion
    assert made is not None, print_widget.message.value
    assert [k.label for k in made.report.key] and len(made.report.key) == 2
    assert (tmp_path / "prints" / "DAPI.layers.ome.tif").is_file()  # what the recipe rebuilds from
    assert made.report.pixel_size_m == pytest.approx(0.2e-6)


@pytest.mark.timeout(300)
@pytest.mark.parametrize("kind, data, words", [
    ("image", np.ones((1, 1), np.uint8), "is 1 × 1 pixels"),
    ("labels", np.zeros((40, 50), np.int32), "has no objects"),
])
def test_a_bad_layer_is_one_message_naming_the_control(print_widget, napari_viewer, tmp_path, qtbot, kind, data, words):
    layer = napari_viewer.add_image(data, name="bad") if kind == "image" else napari_viewer.add_labels(data, name="bad")
    napari_viewer.layers.selection = {layer}
    print_widget.make.native.click()
    text = print_widget.message.value
    assert print_widget.worker is None  # refused before any work
    assert words in text and text.startswith("“Layers”") and "“bad”" in text
    assert text.count(". ") + text.count(".") <= 3 and "Traceback" not in text  # one message, not a log
    assert not (tmp_path / "prints").exists()


@pytest.mark.timeout(300)
def test_a_labels_layer_prints_its_objects(print_widget, napari_viewer, tmp_path, qtbot):
    labels = np.zeros((120, 160), np.int32)
    labels[20:60, 20:60], labels[20:60, 60:100], labels[70:110, 100:140] = 1, 2, 3  # 1 and 2 touch
    layer = napari_viewer.add_labels(labels, name="cells")
    napari_viewer.layers.selection = {layer}
    print_widget.preset.value = "low"
    make_and_wait(print_widget, qtbot)
    assert print_widget.conversion is not None, print_widget.message.value
    assert (tmp_path / "prints" / "cells.stl").is_file()


@pytest.mark.timeout(300)
def test_cancel_stops_before_any_file_is_written(print_widget, napari_viewer, tmp_path, qtbot):
    ramp = np.tile(np.linspace(0, 255, 300, dtype=np.float32), (200, 1))
    napari_viewer.layers.selection = {napari_viewer.add_image(ramp, name="ramp")}
    print_widget.make.native.click()
    assert print_widget.cancel.enabled
    print_widget.cancel.native.click()
    qtbot.waitUntil(lambda: print_widget.make.enabled, timeout=120_000)
    assert print_widget.conversion is None
    assert "Cancelled" in print_widget.message.value
    assert not list((tmp_path / "prints").glob("ramp*"))


def test_every_control_is_labelled_and_reached_with_tab(print_widget):
    from qtpy.QtCore import Qt
    from qtpy.QtWidgets import QWidget

    from tamp_os.napari.controls import CONTROLS

    for name, (words, help_text) in CONTROLS.items():
        control = getattr(print_widget, name)
        assert control.native.accessibleName() == words and control.tooltip == help_text
        takes_tab = [w for w in [control.native, *control.native.findChildren(QWidget)] if w.focusPolicy() & Qt.TabFocus]
        assert takes_tab, f"{words}: not reached with Tab"


@pytest.mark.timeout(300)
def test_an_unusable_output_folder_is_named_by_its_control(print_widget, napari_viewer, tmp_path, qtbot):
    (tmp_path / "taken").write_text("a file, not a folder")
    print_widget.output.value = tmp_path / "taken"
    ramp = np.tile(np.linspace(0, 255, 60, dtype=np.float32), (40, 1))
    napari_viewer.layers.selection = {napari_viewer.add_image(ramp, name="ramp")}
    print_widget.preset.value = "low"
    make_and_wait(print_widget, qtbot)
    text = print_widget.message.value
    assert print_widget.conversion is None and "Traceback" not in text
    assert "taken" in text and "“Output folder”" in text and " -o" not in text, text
