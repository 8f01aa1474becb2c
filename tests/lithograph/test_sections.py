"""Issue 36: a z-stack as a section series (`convert --volume sections:K`): K evenly spaced slices,
each its own relief plate labelled in braille with its place, read back from the STL files."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tifffile
import trimesh
from hypothesis import given, settings, strategies as st

from conftest import examples, run_cli
from tamp_os.lithograph.sections import section_slices

PLANES, STEP_UM = 8, 2.0


def moving_disc_stack(path, planes=PLANES):
    """A bright disc that moves from left to right through the stack (its x = 20 + 20 z px of 200)."""
    yy, xx = np.mgrid[0:120, 0:200]
    stack = np.full((planes, 120, 200), 10, np.uint8)
    for z in range(planes):
        stack[z][(yy - 60) ** 2 + (xx - (20 + 20 * z)) ** 2 < 15**2] = 220
    tifffile.imwrite(path, stack, imagej=True, resolution=(1 / 0.1, 1 / 0.1),
                     metadata={"spacing": STEP_UM, "unit": "um", "axes": "ZYX"})
    return path


@pytest.mark.timeout(60)
@settings(max_examples=examples(60), deadline=None)
@given(planes=st.integers(1, 400), count=st.integers(2, 100))
def test_the_slices_cover_the_stack_evenly(planes, count):
    got = section_slices(planes, count)
    assert len(got) == min(planes, count)
    assert got == sorted(set(got)) and 0 <= got[0] and got[-1] < planes
    if count < planes:  # the middles of equal parts: gaps differ by at most one plane
        gaps = np.diff([-0.5 * planes / count, *got, planes - 1 + 0.5 * planes / count])
        assert gaps.max() - gaps.min() <= planes / count + 1


@pytest.mark.timeout(300)
def test_a_section_series_is_one_plate_per_slice_labelled_with_its_place(tmp_path, capsys):
    stack = moving_disc_stack(tmp_path / "moving.tif")
    code, out, err = run_cli(capsys, "convert", stack, "--volume", "sections:3", "-o", tmp_path / "out", "--formats", "stl",
                             "--width-mm", "80")
    assert code == 0, err
    expected = section_slices(PLANES, 3)
    assert expected == [1, 4, 6]
    centres = []
    for k, z in enumerate(expected, 1):
        out_dir = tmp_path / "out"
        recipe = json.loads((out_dir / f"moving.section-{k}.tamp.json").read_text())
        assert recipe["params"]["z_slice"] == z and recipe["params"].get("sections") is None
        place = f"{k} of 3, z = {z * STEP_UM:g} µm"
        assert recipe["params"]["caption"] == place
        assert f"a braille caption reads: {place}." in (out_dir / f"moving.section-{k}.description.txt").read_text()
        mesh = trimesh.load(out_dir / f"moving.section-{k}.stl")
        assert mesh.is_watertight and mesh.volume > 0
        top = mesh.vertices[mesh.vertices[:, 2] > mesh.vertices[:, 2].max() - 0.5]
        centres.append(float(np.median(top[:, 0])))
    # the disc moves right through the stack, and so from plate to plate (x = 20 + 20 z of 200 px, on 80 mm)
    # (the picture sits inside the plate's margin, so the plates are compared with each other)
    for (z0, x0), (z1, x1) in zip(zip(expected, centres), zip(expected[1:], centres[1:])):
        assert x1 - x0 == pytest.approx(80 * 20 * (z1 - z0) / 199, abs=2.0), centres
    assert "a series of 3 sections (z = 2 µm, z = 8 µm, z = 12 µm)" in out


@pytest.mark.timeout(120)
def test_a_single_plane_or_a_model_and_sections_at_once_is_one_clear_error(tmp_path, capsys):
    flat = tmp_path / "flat.tif"
    tifffile.imwrite(flat, np.tile(np.linspace(0, 255, 64, dtype=np.uint8), (48, 1)))
    code, out, err = run_cli(capsys, "convert", flat, "--volume", "sections:4", "-o", tmp_path / "out")
    assert code == 1 and err.count("error:") == 1 and "one plane, so there is no series of sections" in err, err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    stack = moving_disc_stack(tmp_path / "moving.tif")
    code, out, err = run_cli(capsys, "convert", stack, "--volume", "--sections", "3", "-o", tmp_path / "out2")
    assert code != 0 and "give one of them" in err, err
    code, out, err = run_cli(capsys, "convert", stack, "--volume", "sections:1", "-o", tmp_path / "out3")
    assert code == 2 and "sections" in err, err
