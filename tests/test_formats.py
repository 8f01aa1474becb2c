"""The format table (formats.py): every list of formats reads it, and what it says holds for the
files actually written."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import run_cli
from tamp_os import formats
from tamp_os.export import _registry, format_of
from tamp_os.params import FORMATS, LithoParams

pytestmark = pytest.mark.timeout(300)


def test_every_list_of_formats_is_the_table():
    assert FORMATS == formats.NAMES == tuple(f.name for f in formats.TABLE)
    assert set(_registry()) == set(formats.MESH_FORMATS)
    field = next(f for f in dataclasses.fields(LithoParams) if f.name == "formats")
    assert field.metadata["choices"] == formats.NAMES
    from tamp_os.gui.routes import FORMATS as web_formats
    from tamp_os.export.meshfile import MESH_SUFFIXES
    from tamp_os.lithograph.render import MESH_SUFFIXES as render_suffixes

    assert web_formats == formats.NAMES
    assert MESH_SUFFIXES == render_suffixes == formats.READABLE_MESH_SUFFIXES
    assert format_of("a.stp") == "step" and format_of("A.STL") == "stl"


def test_each_format_says_what_it_is_for_in_one_plain_sentence():
    """One sentence each ("For ...: ..."), read by --help, the web form, the web app's file list
    and the README (issue 54); no engine words a reader would not know."""
    for f in formats.TABLE:
        assert f.purpose.startswith("For ") and f.purpose.endswith("."), f.name
        assert ". " not in f.purpose[:-1] and 20 <= len(f.purpose) <= 140, (f.name, f.purpose)
        assert not any(word in f.purpose for word in ("Update Display", "IMAGE profile", "`", "_")), (f.name, f.purpose)
    assert len({f.purpose for f in formats.TABLE}) == len(formats.TABLE)


def test_graphics_are_not_estimated_and_meshes_are():
    for f in formats.TABLE:
        estimate = f.estimate_bytes(10_000, 5_000)
        assert (estimate is None) == (f.kind != "mesh"), f.name
        if estimate is not None:
            assert estimate > 0


@pytest.mark.parametrize("name", formats.MESH_FORMATS)
def test_size_estimate_is_within_a_factor_of_three_of_the_file(tmp_path, name):
    """The estimate is a rough guide; it must not be off by orders of magnitude."""
    from tamp_os import make_lithograph

    yy, xx = np.mgrid[0:96, 0:128]
    litho = make_lithograph(np.hypot(xx - 64, yy - 48), preset="low", scale_bar="off", orientation_corner="none")
    path = litho.save(tmp_path / f"x{formats.BY_NAME[name].suffix}")[0]
    estimate = formats.estimate_bytes(name, litho.mesh.n_triangles, len(litho.mesh.vertices))
    assert path.stat().st_size / 3 < estimate < path.stat().st_size * 3, (name, estimate, path.stat().st_size)


def test_presets_with_a_graphic_format_says_not_estimated(tmp_path, capsys):
    """Bug: `tamp-os presets IMAGE --formats stl,pdf` ended in a KeyError traceback."""
    from PIL import Image

    image = tmp_path / "ramp.png"
    Image.fromarray(np.tile(np.arange(0, 256, 2, dtype=np.uint8), (96, 1))).save(image)
    code, out, err = run_cli(capsys, "presets", image, "--formats", "stl,pdf")
    assert code == 0, err
    assert "PDF not estimated" in out and "STL " in out and "Traceback" not in err
