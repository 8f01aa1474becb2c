"""The whole chain: orientation, bit depth, sizing, presets, uniform images."""

import numpy as np
import pytest
import tifffile
from PIL import Image

from tamp_os import LithoParams, make_lithograph
from tamp_os.errors import ParameterError
from tamp_os.printing.printers import grid_triangles, height_levels, preset_resolution_px
from tamp_os.mesh.validate import check_solid


def top_height_at(mesh, x, y):
    """Height of the top surface at the grid vertex nearest (x, y) on the print."""
    top = mesh.vertices[mesh.vertices[:, 2] > 0]
    i = np.argmin((top[:, 0] - x) ** 2 + (top[:, 1] - y) ** 2)
    return top[i, 2]


def test_print_seen_from_above_looks_like_the_image(gradient_image):
    litho = make_lithograph(gradient_image, relief_style="reference", width_mm=64, resolution_px=64, blur_px=0, mesher="grid")
    w, d = litho.layout.width_mm, litho.layout.depth_mm
    # The bright block sits at the image's top left -> far left of the print (small x, large y).
    assert top_height_at(litho.mesh, 0.15 * w, 0.8 * d) == pytest.approx(4.0, abs=0.05)
    assert top_height_at(litho.mesh, 0.15 * w, 0.2 * d) < 1.5  # near left: dark end of the ramp
    # The ramp rises to the right.
    assert top_height_at(litho.mesh, 0.95 * w, 0.2 * d) > top_height_at(litho.mesh, 0.5 * w, 0.2 * d) + 0.5
    mirrored = make_lithograph(gradient_image, relief_style="reference", width_mm=64, resolution_px=64, blur_px=0, flip_x=True, mesher="grid")
    assert top_height_at(mirrored.mesh, 0.85 * w, 0.8 * d) == pytest.approx(4.0, abs=0.05)


def test_invert_raises_dark_parts(gradient_image):
    plain = make_lithograph(gradient_image, relief_style="reference", resolution_px=32, blur_px=0)
    inverted = make_lithograph(gradient_image, relief_style="reference", resolution_px=32, blur_px=0, invert=True)
    total = plain.params.base_mm * 2 + plain.params.relief_mm
    np.testing.assert_allclose(plain.heightmap + inverted.heightmap, total, atol=1e-5)


def test_16bit_and_float_tiffs_give_the_8bit_relief(tmp_path, fixture):
    base = np.asarray(Image.open(fixture("fept_spheres_sem.png")).convert("L"))
    tifffile.imwrite(tmp_path / "p8.tif", base)
    tifffile.imwrite(tmp_path / "p16.tif", base.astype(np.uint16) * 257)
    tifffile.imwrite(tmp_path / "pf.tif", base.astype(np.float32) / 255.0)
    reliefs = [make_lithograph(tmp_path / n, relief_style="reference", preset="low").heightmap for n in ("p8.tif", "p16.tif", "pf.tif")]
    assert reliefs[0].max() - reliefs[0].min() > 2.9  # a real relief, not the reference's flat plate
    np.testing.assert_allclose(reliefs[1], reliefs[0], atol=1e-4)
    np.testing.assert_allclose(reliefs[2], reliefs[0], atol=1e-4)


def test_uniform_image_gives_flat_plate_and_warning(fixture):
    litho = make_lithograph(fixture("JEOL-SightX-TEM-mag-dummy.tif"), preset="low")
    assert litho.report["uniform"]
    assert np.all(litho.heightmap == litho.params.base_mm)
    assert any("uniform" in w for w in litho.report["warnings"])
    check = check_solid(litho.mesh)
    # a 100 × 100 × 1 mm plate less its cut corner (legs of 8 mm)
    assert check.ok and check.volume_mm3 == pytest.approx(100 * 100 * 1.0 - 8 * 8 / 2 * 1.0, rel=1e-6)


def test_fixtures_convert_to_valid_solids(fixtures_dir):
    for path in sorted(fixtures_dir.glob("*.tif")) + [fixtures_dir / "fept_spheres_sem.png"]:
        litho = make_lithograph(path, preset="low")
        assert check_solid(litho.mesh).ok, path.name
        assert np.isfinite(litho.mesh.vertices).all()


def test_sizes_aspect_and_fit(gradient_image):
    litho = make_lithograph(gradient_image, relief_style="reference", depth_mm=60)
    assert litho.layout.width_mm == pytest.approx(80)
    lo, hi = litho.mesh.bounds_mm
    np.testing.assert_allclose(hi[:2], [80, 60])
    padded = make_lithograph(gradient_image, relief_style="reference", width_mm=80, height_mm=80)  # the old name still works
    assert any("depth_mm to 60.0" in w for w in padded.report["warnings"]) and padded.params.depth_mm == 80
    np.testing.assert_allclose(padded.mesh.bounds_mm[1][:2], [80, 80])
    # Padding prints at base level along the top and bottom edges.
    assert np.all(padded.heightmap[0] == 1.0) and np.all(padded.heightmap[-1] == 1.0)
    cropped = make_lithograph(gradient_image, relief_style="reference", width_mm=80, depth_mm=80, fit="crop")
    assert not cropped.report["warnings"]
    assert cropped.heightmap[-1].max() > 1.5  # image content reaches the edge


def test_presets_follow_the_nozzle():
    assert preset_resolution_px("low", 0.4, 100) == 125
    assert preset_resolution_px("medium", 0.4, 100) == 250
    assert preset_resolution_px("high", 0.4, 100) == 500
    assert height_levels(3.0, 0.12) == 25
    litho = make_lithograph(np.eye(40) * 255, preset="high", printer="fine", mesher="grid", orientation_corner="none")
    assert litho.report["grid"][0] == 800 and litho.report["layer_mm"] == 0.08
    assert litho.mesh.n_triangles == grid_triangles(*litho.report["grid"])


def test_blur_in_mm_equals_blur_in_output_pixels(gradient_image):
    a = make_lithograph(gradient_image, width_mm=63, resolution_px=64, blur_px=2.0)
    b = make_lithograph(gradient_image, width_mm=63, resolution_px=64, blur_mm=2.0)  # 1 mm per pixel
    np.testing.assert_allclose(a.heightmap, b.heightmap, atol=1e-6)


def test_quantize_to_layers(gradient_image):
    litho = make_lithograph(gradient_image, relief_style="reference", quantize=True, layer_mm=0.2, resolution_px=40)
    relief = litho.heightmap - 1.0
    np.testing.assert_allclose(relief / 0.2, np.round(relief / 0.2), atol=1e-9)


def test_percentiles_come_from_the_source_not_the_output_grid(fixture):
    low = make_lithograph(fixture("fept_spheres_sem.png"), relief_style="reference", resolution_px=64, blur_px=0)
    high = make_lithograph(fixture("fept_spheres_sem.png"), relief_style="reference", resolution_px=512, blur_px=0)
    # Same picture, same meaning: the mean height barely depends on the grid.
    assert abs(low.heightmap.mean() - high.heightmap.mean()) < 0.05


def test_api_changes_are_validated_parameters():
    with pytest.raises(ParameterError, match="relief_mm"):
        make_lithograph(np.eye(8), relief_mm=0)
    with pytest.raises(ParameterError, match="unknown parameter"):
        make_lithograph(np.eye(8), relif_mm=2)
    p = LithoParams(relief_mm=2.5, formats=("stl", "3mf"))
    assert LithoParams.from_json(p.to_json()) == p


def test_a_picture_that_is_mostly_noise_is_said_to_be(fixture):
    # the DM3 fixture is noise (91 % of its contrast); its print was "27 raised shapes" with no word of it
    rng = np.random.default_rng(3)
    noisy = make_lithograph(rng.normal(0.5, 0.1, (64, 64)).astype(np.float32), width_mm=60, scale_bar="off")
    assert any("mostly noise" in w for w in noisy.report.warnings), noisy.report.warnings
    yy, xx = np.mgrid[0:64, 0:64]
    clean = (np.hypot(xx - 32, yy - 32) < 15).astype(np.float32) + rng.normal(0, 0.03, (64, 64)).astype(np.float32)
    assert not any("noise" in w for w in make_lithograph(clean, width_mm=60, scale_bar="off").report.warnings)
    dm3 = make_lithograph(fixture("test_STEM_image.dm3"), scale_bar="off")
    assert any("mostly noise" in w for w in dm3.report.warnings), dm3.report.warnings
