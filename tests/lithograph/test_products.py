"""lithograph/products.py, the one product entry point (issue 52.1): the product follows from the
settings, a format it cannot write is refused before any work, and every front end's path (the CLI,
batch) gets every product from it."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile

from cli_support import run_cli_child
from tamp_os import LithoParams
from tamp_os.errors import ParameterError
from tamp_os.lithograph.products import Product, convert, product_of

pytestmark = pytest.mark.timeout(300)


def test_the_product_follows_from_the_settings():
    assert product_of(LithoParams()) is Product.RELIEF
    assert product_of(LithoParams(volume=True)) is Product.VOLUME
    assert product_of(LithoParams(sections=3)) is Product.SECTIONS
    assert Product.VOLUME.formats == ("stl", "3mf", "glb", "obj", "ply", "step")
    assert "tour" in Product.RELIEF.formats and "dotpad" in Product.SECTIONS.formats


@pytest.mark.parametrize("formats", [("stl", "tour"), ("pdf",), ("ebraille", "dotpad")])
def test_a_format_the_product_cannot_write_is_refused_before_the_source_is_read(tmp_path, formats):
    missing = tmp_path / "no such stack.tif"  # never opened: the refusal comes first
    with pytest.raises(ParameterError) as refused:
        convert(missing, LithoParams(volume=True, formats=formats), tmp_path / "out")
    said = str(refused.value)
    assert "stl, 3mf, glb, obj, ply, step" in said and all(f in said for f in formats if f != "stl")
    assert not (tmp_path / "out").exists()


def test_a_relief_is_one_conversion_with_its_files(tmp_path):
    ramp = np.tile(np.linspace(0, 1, 80), (60, 1))
    made = convert(ramp, LithoParams(width_mm=40, preset="low"), tmp_path, stem="ramp")
    assert made.product is Product.RELIEF and made.model is None and len(made.conversions) == 1
    assert [p.name for p in made.all_written] == ["ramp.stl", "ramp.description.txt", "ramp.tamp.json"]
    assert all(p.is_file() for p in made.all_written)


@pytest.mark.slow
def test_batch_makes_a_section_series_through_the_entry_point(tmp_path):
    """Batch refused `sections` before the entry point ('batch ... do not make them yet')."""
    folder = tmp_path / "stacks"
    folder.mkdir()
    z, y, x = np.mgrid[:4, :40, :50]
    tifffile.imwrite(folder / "stack.tif", ((x + 10 * z) * 4).astype(np.uint8), imagej=True, metadata={"axes": "ZYX"})
    code, err, _, _, _ = run_cli_child("batch", folder, "-o", tmp_path / "out", "--sections", "2", "--formats", "stl",
                                       "--width-mm", "40", "--preset", "low", timeout_s=240)
    assert code == 0, err
    plates = sorted(p.name for p in (tmp_path / "out").glob("*.stl"))
    assert plates == ["stack.section-1.stl", "stack.section-2.stl"]
