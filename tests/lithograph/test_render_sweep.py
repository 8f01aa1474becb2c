"""Rendered previews and sweeps: real offscreen renders, labelled contact sheets, alt text."""

import numpy as np
import pytest
from PIL import Image

from tamp_os import make_lithograph
from tamp_os.cli.commands import main
from tamp_os.errors import ParameterError
from tamp_os.lithograph.sweep import parse_vary


@pytest.fixture(scope="module")
def stl(tmp_path_factory):
    folder = tmp_path_factory.mktemp("mesh")
    y, x = np.mgrid[0:60, 0:80]
    litho = make_lithograph(np.sin(x / 6) + np.cos(y / 8), width_mm=60, preset="low")
    return litho.save(folder / "waves.stl")[0]


def test_render_writes_nonblank_full_and_closeup_of_the_requested_size(stl, tmp_path, capsys):
    assert main(["render", str(stl), "-o", str(tmp_path), "--size", "640x480", "--theme", "dark"]) == 0
    for kind in ("full", "closeup"):
        png = tmp_path / "renders" / kind / "waves.png"
        image = np.asarray(Image.open(png).convert("RGB"))
        assert image.shape == (480, 640, 3)
        corner = image[:10, :10].mean()
        assert corner < 60  # dark theme background
        assert image.std() > 10 and (np.abs(image.astype(int) - corner).sum(axis=2) > 60).mean() > 0.05
        alt = (tmp_path / "renders" / kind / "waves.alt.txt").read_text(encoding="utf-8")
        assert "tactile relief waves" in alt and "60 by" in alt
    full = np.asarray(Image.open(tmp_path / "renders" / "full" / "waves.png"))
    close = np.asarray(Image.open(tmp_path / "renders" / "closeup" / "waves.png"))
    assert not np.array_equal(full, close)


def test_render_options_are_checked(stl, tmp_path, capsys):
    assert main(["render", str(stl), "-o", str(tmp_path), "--elevation", "120"]) == 2
    assert "elevation" in capsys.readouterr().err


def test_sweep_sheet_has_one_labelled_panel_per_value(fixture, tmp_path, capsys):
    out = tmp_path / "sweep"
    assert main(["sweep", str(fixture("fept_spheres_sem.png")), "--vary", "resolution=64,96,128", "-o", str(out)]) == 0
    for value in (64, 96, 128):
        assert (out / f"fept_spheres_sem_resolution_{value}.stl").is_file()
    sheet = np.asarray(Image.open(out / "fept_spheres_sem_sweep_heightmaps.png").convert("L"))
    assert sheet.shape == (320 + 36, 3 * 320)
    for i in range(3):
        panel = sheet[:320, i * 320 : (i + 1) * 320]
        label = sheet[320:, i * 320 : (i + 1) * 320]
        assert panel.std() > 10 and (label < 128).sum() > 50  # an image and dark label text in each
    alt = (out / "fept_spheres_sem_sweep_heightmaps.alt.txt").read_text(encoding="utf-8")
    assert "resolution 64; resolution 96; resolution 128" in alt
    renders = np.asarray(Image.open(out / "fept_spheres_sem_sweep_renders.png").convert("L"))
    assert renders.shape == sheet.shape and renders[:320].std() > 5


def test_vary_grid_and_errors():
    assert parse_vary(["resolution=64,128", "relief=2,3.5", "invert=false,true"]) == {
        "resolution_px": [64, 128], "relief_mm": [2.0, 3.5], "invert": [False, True],
    }
    from tamp_os import LithoParams
    from tamp_os.lithograph.sweep import variants

    names = [suffix for suffix, _ in variants(LithoParams(), parse_vary(["resolution=64,128", "invert=false,true"]))]
    assert names == ["resolution_64_invert_False", "resolution_64_invert_True", "resolution_128_invert_False", "resolution_128_invert_True"]
    with pytest.raises(ParameterError, match="NAME=V1"):
        parse_vary(["nonsense=1"])
    with pytest.raises(ParameterError, match="whole number"):
        parse_vary(["resolution=abc"])


def test_a_folder_renders_each_print_once(tmp_path):
    from tamp_os.lithograph.render import find_meshes

    for name in ("a.stl", "a.3mf", "a.glb", "b.obj", "b.ply", "c.txt"):
        (tmp_path / name).write_bytes(b"")
    assert [p.name for p in find_meshes([tmp_path])] == ["a.stl", "b.obj"]
