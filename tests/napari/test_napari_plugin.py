"""The plugin's manifest, reader, writers and words: npe2 validates the manifest and napari opens
and saves through it; the reader gives a layer per channel at the file's scale; the writers print
layers through the pipeline; messages name the widget's controls and leave out advice about
controls it does not have."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT
from napari_support import headless_display, napari_plugin, napari_viewer  # noqa: F401


@pytest.mark.timeout(120)
def test_npe2_validates_the_manifest_with_its_imports(napari_plugin):
    npe2 = [sys.executable, "-c", "import sys; from npe2.cli import main; sys.argv[0] = 'npe2'; main()"]
    done = subprocess.run([*npe2, "validate", str(napari_plugin), "--imports"], capture_output=True, text=True, timeout=110,
                          env={"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stdout + done.stderr
    assert "valid" in done.stdout


def test_the_package_declares_the_manifest(napari_plugin):
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert project["project"]["entry-points"]["napari.manifest"]["tamp-os"] == "tamp_os.napari:napari.yaml"
    assert "napari/napari.yaml" in project["tool"]["setuptools"]["package-data"]["tamp_os"]
    extras = project["project"]["optional-dependencies"]
    assert {"napari", "magicgui", "npe2"} <= {r.split(">")[0].split("[")[0] for r in extras["napari"]}
    assert "napari" not in extras["all"][0]  # the extra stays out of the core install and of `all`


@pytest.mark.timeout(300)
def test_napari_opens_a_czi_and_saves_an_stl_through_the_manifest(napari_viewer, napari_plugin, fixture, tmp_path):
    import npe2

    manager = npe2.PluginManager.instance()
    if "tamp-os" not in manager.iter_manifests() and "tamp-os" not in {m.name for m in manager.iter_manifests()}:
        manager.register(npe2.PluginManifest.from_file(napari_plugin))  # an editable install of an older tree lacks the entry point
    czi = fixture("real/zeiss_dapi_gfp_2ch.czi")
    layers = napari_viewer.open(str(czi), plugin="tamp-os")
    assert [layer.name for layer in layers] == ["zeiss_dapi_gfp_2ch DAPI", "zeiss_dapi_gfp_2ch GFP"] or len(layers) == 2
    assert all(layer.metadata["tamp_os"]["path"] == str(czi) for layer in layers)
    written = napari_viewer.layers.save(str(tmp_path / "cells.stl"), selected=False, plugin="tamp-os")
    assert sorted(n.rsplit("/", 1)[-1] for n in written) == ["cells.description.txt", "cells.stl", "cells.tamp.json"]
    import trimesh

    mesh = trimesh.load(tmp_path / "cells.stl")
    mesh.merge_vertices()
    assert mesh.is_watertight and mesh.volume > 0


@pytest.mark.timeout(300)
def test_the_reader_takes_vendor_files_only_and_gives_their_scale(napari_plugin, fixture):
    from tamp_os.napari.reader import napari_get_reader

    assert napari_get_reader(str(fixture("fept_spheres_sem.png"))) is None  # napari reads PNG itself
    dm3 = fixture("test_STEM_image.dm3")
    read = napari_get_reader(str(dm3))
    assert read is not None
    (data, keywords, kind), = read(str(dm3))
    assert kind == "image" and data.ndim == 2
    assert keywords["units"] == ("micrometer", "micrometer")
    mark = keywords["metadata"]["tamp_os"]
    assert keywords["scale"][0] == pytest.approx(mark["pixel_size_m"] * 1e6)
    channels = napari_get_reader(str(fixture("real/zeiss_dapi_gfp_2ch.czi")))(str(fixture("real/zeiss_dapi_gfp_2ch.czi")))
    assert [k["metadata"]["tamp_os"]["channel"] for _, k, _ in channels] == [0, 1]
    assert all(k["blending"] == "additive" for _, k, _ in channels)


@pytest.mark.timeout(300)
def test_the_writer_prints_a_layer_at_its_scale(napari_plugin, tmp_path):
    from tamp_os.napari.writer import write_3mf

    ramp = np.tile(np.linspace(0, 255, 90, dtype=np.float32), (60, 1))
    meta = {"name": "ramp", "scale": (0.5, 0.5), "units": ("micrometer", "micrometer"), "metadata": {}}
    written = write_3mf(str(tmp_path / "ramp.3mf"), [(ramp, meta, "image")])
    assert [p.rsplit("/", 1)[-1] for p in written] == ["ramp.3mf", "ramp.description.txt", "ramp.tamp.json"]
    import json

    recipe = json.loads((tmp_path / "ramp.tamp.json").read_text(encoding="utf-8"))
    assert recipe["params"]["pixel_size"] == pytest.approx(0.5e-6)  # the layer's scale, in metres


def test_a_bad_layer_saved_is_one_plain_message(napari_plugin, tmp_path):
    from tamp_os.napari.writer import write_stl

    with pytest.raises(ValueError) as caught:
        write_stl(str(tmp_path / "dot.stl"), [(np.ones((1, 1)), {"name": "dot"}, "image")])
    assert str(caught.value).startswith("“Layers”: the image layer “dot” is 1 × 1 pixels")
    assert not list(tmp_path.iterdir())


def test_messages_name_the_widgets_controls_and_leave_out_the_others():
    from tamp_os.errors import ParameterError, Text
    from tamp_os.napari.controls import widget_words

    text = widget_words(Text("the picture was printed channel by channel⟦; `channel` prints a single channel⟧⟦, and "
                             "`relief_style` levels gives plateaus⟧."))
    assert text == "The picture was printed channel by channel, and “Relief style” levels gives plateaus."
    error = ParameterError("`preset`: must be low, medium or high.", hint="Lower `max_megapixels`.")
    assert widget_words(error) == "“Level of detail”: must be low, medium or high."
    assert widget_words(Text("`pixel_size` 4 nm overrides 5 nm from the file.")).startswith("The layer's scale")


def test_the_result_message_spells_the_file_as_on_the_disk_and_ends_each_sentence(tmp_path):
    from tamp_os.napari.controls import result_words

    said = result_words("fept_spheres_sem.png: 116 × 99.5 × 4 mm; wrote fept_spheres_sem.{stl,3mf}, its description and recipe",
                        tmp_path)
    assert said == ("fept_spheres_sem.png: 116 × 99.5 × 4 mm; wrote fept_spheres_sem.{stl,3mf}, its description and recipe. "
                    f"The files are in {tmp_path}.")
    counted = result_words(f"a.png: 100 × 100 × 4 mm; wrote 7 files to {tmp_path}/", tmp_path)
    assert counted == f"a.png: 100 × 100 × 4 mm; wrote 7 files to {tmp_path}/."  # the folder said once


def test_a_layer_from_a_file_keeps_it_unless_its_scale_was_set(tmp_path):
    from tamp_os.napari.layers import LayerPicture, print_source

    png = tmp_path / "p.png"
    from PIL import Image

    Image.fromarray(np.zeros((20, 30), np.uint8)).save(png)
    plain = LayerPicture("p", "image", np.zeros((20, 30), np.uint8), path=str(png))
    assert print_source([plain], tmp_path).source == str(png)
    scaled = LayerPicture("p", "image", np.zeros((20, 30), np.uint8), (2.0, 2.0), ("nanometer", "nanometer"), str(png))
    chosen = print_source([scaled], tmp_path)
    assert isinstance(chosen.source, np.ndarray) and chosen.pixel_size_m == pytest.approx(2e-9)
