"""The one result line per converted file, as a screen reader reads it from `tamp-os convert`
(issue 54.5): a name is never cut (a cut name is not on the disk, and one name cut two ways reads
as two files); a line that would pass 160 characters names the folder and the count instead of
the files; a 3-D model's line keeps to the same rule, and where its thin walls are is said in its
description, not in a warning line."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile
from PIL import Image

from cli_support import run_tamp

MAX = 160  # docs/command-line.md: "one line of at most 160 characters per file"


def noise_png(path, shape=(60, 80), seed=0):
    Image.fromarray((np.random.default_rng(seed).random(shape) * 255).astype(np.uint8)).save(path)
    return path


@pytest.mark.timeout(300)
def test_long_names_are_said_whole_and_the_line_names_the_folder_and_count(tmp_path):
    # two exports from one microscope: long names that differ only near their ends
    names = [f"JEOL-SightX-TEM-session-2024-03-14-grid-{k}-mag-40000x-dummy.png" for k in ("A3", "B7")]
    for k, name in enumerate(names):
        noise_png(tmp_path / name, seed=k)
    done = run_tamp("convert", *names, "-o", "out", "--formats", "stl,3mf,glb,pdf,svg", "--width-mm", "40", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 2, lines
    for name, line in zip(names, lines):
        assert line.startswith(f"{name}: "), line  # the name whole, as on the disk
        assert "…" not in line and len(line) <= MAX, line
        assert line.endswith("; wrote 7 files to out/"), line  # five formats, the description and the recipe
    assert len(list((tmp_path / "out").iterdir())) == 14


@pytest.mark.timeout(300)
def test_a_short_name_keeps_its_files_named(tmp_path):
    noise_png(tmp_path / "ramp.png")
    done = run_tamp("convert", "ramp.png", "-o", "out", "--formats", "stl,3mf", "--width-mm", "40", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    line = done.stdout.splitlines()[0]
    assert line.startswith("ramp.png: ") and line.endswith("; wrote ramp.{stl,3mf}, its description and recipe"), line
    assert len(line) <= MAX


@pytest.mark.timeout(300)
def test_a_name_longer_than_the_line_is_still_said_whole(tmp_path):
    name = "a-very-long-file-name-from-a-microscope-export-" + "x" * 120 + ".png"
    noise_png(tmp_path / name)
    done = run_tamp("convert", name, "-o", "o", "--formats", "stl,3mf", "--width-mm", "40", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    line = done.stdout.splitlines()[0]
    assert line.startswith(f"{name}: ") and "…" not in line, line
    assert line.endswith("; wrote 4 files to o/") and "grid" not in line, line  # as short as the name allows


def beads_stack(path):
    """Two beads in a z-stack with its voxel size, as ImageJ writes it (docs' STACK)."""
    z, y, x = np.mgrid[:12, :40, :40]
    beads = ((x - 13) ** 2 + (y - 20) ** 2 + ((z - 6) * 2) ** 2 < 64) | ((x - 28) ** 2 + (y - 20) ** 2 + ((z - 6) * 2) ** 2 < 49)
    tifffile.imwrite(path, (beads * 200 + 10).astype(np.uint8), imagej=True,
                     resolution=(1 / 0.2, 1 / 0.2), metadata={"spacing": 0.4, "unit": "um", "axes": "ZYX"})
    return path


@pytest.mark.timeout(300)
def test_a_volume_line_keeps_to_the_line_length(tmp_path):
    beads_stack(tmp_path / "confocal_beads_zstack_41z.tif")
    done = run_tamp("convert", "confocal_beads_zstack_41z.tif", "--volume", "-o", "out_vol", "--formats", "stl,3mf,glb", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("confocal_beads_zstack_41z.tif: 3-D model "), lines[0]
    assert all(len(line) <= MAX for line in lines), [len(line) for line in lines]
    assert "thinnest wall" in lines[0] and lines[0].endswith("; wrote 5 files to out_vol/"), lines[0]


def plates_stack(path):
    """Two plates 0.5 mm thick and 0.5 mm apart (1 µm = 1 mm of model): thickened to 1 mm they
    would touch, so both are left thin (tests/lithograph/test_volume.py)."""
    pitch = 0.2
    z, y, x = np.meshgrid((np.arange(50) + 0.37) * pitch, (np.arange(50) + 0.41) * pitch, (np.arange(45) + 0.43) * pitch, indexing="ij")
    y = 50 * pitch - y

    def plate(cx):
        return np.minimum(0.25 - np.abs(x - cx), np.minimum(3.5 - np.abs(y - 5), 3.5 - np.abs(z - 5)))

    share = np.clip(0.5 + np.maximum(plate(4.0), plate(5.0)) / pitch, 0, 1)
    tifffile.imwrite(path, (100 + 1000 * share).astype(np.uint16), imagej=True, resolution=(1 / pitch, 1 / pitch),
                     metadata={"spacing": pitch, "unit": "um", "axes": "ZYX"})
    return path


@pytest.mark.timeout(300)
def test_where_thin_walls_are_is_in_the_description_not_the_warning(tmp_path):
    plates_stack(tmp_path / "two.tif")
    done = run_tamp("convert", "two.tif", "--volume", "--volume-stand", "none", "--iso-level", "600", "--size-mm", "7.5",
                    "--min-wall-mm", "1", "-o", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    warning = next(line for line in done.stderr.splitlines() if "thin part" in line)
    assert warning.startswith("warning: 2 thin parts left thinner than 1 mm (thinnest 0."), warning
    assert "at x " not in warning and "--size-mm" in warning and len(warning) <= MAX, warning  # no boxes of coordinates
    described = (tmp_path / "out" / "two.description.txt").read_text(encoding="utf-8")
    assert "mm thick at x " in described  # where: each part's box, in the description
