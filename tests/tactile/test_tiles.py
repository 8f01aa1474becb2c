"""Tiles for prints larger than the bed (issue 15.3): tiles read back from STL with trimesh."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings, strategies as st

from tamp_os.errors import ParameterError
from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.tactile.tiles import (CLEARANCE_MM, HEAD_DIAMETER_MM, REACH_MM, cell_edges, parse_bed_mm, plan_grid, tile_label,
                           tiles_along)
from conftest import examples

BED = (120.0, 120.0)


@pytest.fixture(scope="module")
def tiled(tmp_path_factory):
    image = np.random.default_rng(5).random((90, 150))
    litho = make_lithograph(image, width_mm=200, caption="⠠⠞⠑⠎⠞", bed_mm="120", formats=("stl",))
    folder = tmp_path_factory.mktemp("tiles")
    litho.save(folder, stem="p")
    whole = litho.mesh
    tiles = {(t.row, t.col): trimesh.load(folder / f"p.tile-{t.row}-{t.col}.stl") for t in litho.tiles.tiles}
    return litho, tiles, trimesh.Trimesh(whole.vertices, whole.faces), folder


@pytest.mark.timeout(30)
def test_parse_bed_mm():
    assert parse_bed_mm("120") == (120.0, 120.0)
    assert parse_bed_mm("120x200") == (120.0, 200.0)
    assert parse_bed_mm(" 250 X 210 mm".lower()) == (250.0, 210.0)
    for bad in ("", "abc", "120x", "10", "120x-5", "5000"):
        with pytest.raises(ParameterError, match="bed_mm"):
            parse_bed_mm(bad)


@pytest.mark.timeout(60)
@settings(max_examples=examples(200), deadline=None)
@given(st.floats(10, 1500), st.floats(60, 400))
def test_fewest_tiles_that_fit(length_mm, bed_mm):
    count = tiles_along(length_mm, bed_mm)
    edges = cell_edges(length_mm, count)
    sizes = [b - a + (REACH_MM if i < count - 1 else 0.0) for i, (a, b) in enumerate(zip(edges, edges[1:]))]
    assert max(sizes) <= bed_mm + 1e-6  # every tile, with its peg, fits
    assert min(b - a for a, b in zip(edges, edges[1:])) > 0
    assert edges[0] == 0 and edges[-1] == length_mm
    if count > 1:  # one tile fewer would not fit: its tiles would have to be longer than the bed
        fewer = count - 1
        assert (length_mm + (fewer - 1) * REACH_MM) / fewer > bed_mm - 1e-6


@pytest.mark.timeout(30)
def test_grid_may_turn_the_bed():
    assert plan_grid((100.0, 100.0), (120.0, 120.0))[:2] == (1, 1)
    rows, cols, turned = plan_grid((190.0, 110.0), (120.0, 200.0))
    assert (rows, cols, turned) == (1, 1, True)


@pytest.mark.timeout(30)
def test_tile_label_is_row_then_column_in_braille_numbers():
    assert tile_label(1, 2) == "⠼⠁⠀⠼⠃"
    assert tile_label(2, 10) == "⠼⠃⠀⠼⠁⠚"


@pytest.mark.timeout(300)
def test_each_tile_is_closed_and_fits_the_bed(tiled):
    litho, tiles, whole, _ = tiled
    assert litho.tiles.rows * litho.tiles.cols == len(tiles) == 4
    assert max(whole.extents[:2]) > BED[0]
    for key, mesh in tiles.items():
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, key
        w, d = mesh.extents[:2]
        assert (w <= BED[0] + 1e-6 and d <= BED[1] + 1e-6) or (d <= BED[0] + 1e-6 and w <= BED[1] + 1e-6), key


def _inside(mesh: trimesh.Trimesh, points: np.ndarray) -> np.ndarray:
    """Point in solid by the parity of an upward ray's crossings (numpy only: trimesh.contains
    needs rtree). The rays are nudged by an irrational offset so they miss edges and vertices."""
    tri = np.asarray(mesh.triangles)
    lo, hi = tri[:, :, :2].min(axis=1), tri[:, :, :2].max(axis=1)
    out = np.zeros(len(points), dtype=bool)
    for i, (x, y, z) in enumerate(np.asarray(points) + [math.pi * 1e-7, math.e * 1e-7, 0.0]):
        near = (lo[:, 0] <= x) & (hi[:, 0] >= x) & (lo[:, 1] <= y) & (hi[:, 1] >= y)
        a, b, c = tri[near, 0], tri[near, 1], tri[near, 2]
        det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
        ok = np.abs(det) > 1e-15
        a, b, c, det = a[ok], b[ok], c[ok], det[ok]
        u = ((x - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (y - a[:, 1])) / det
        v = ((b[:, 0] - a[:, 0]) * (y - a[:, 1]) - (x - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
        hit = (u >= 0) & (v >= 0) & (u + v <= 1)
        zs = a[hit, 2] + u[hit] * (b[hit, 2] - a[hit, 2]) + v[hit] * (c[hit, 2] - a[hit, 2])
        out[i] = int((zs > z).sum()) % 2 == 1
    return out


@pytest.mark.timeout(300)
def test_pegs_fit_sockets_with_the_clearance(tiled):
    litho, tiles, _, _ = tiled
    z = litho.params.base_mm / 2
    radius = HEAD_DIAMETER_MM / 2
    assert litho.tiles.joints
    for joint in litho.tiles.joints:
        peg, socket = tiles[joint.peg_tile], tiles[joint.socket_tile]
        hx, hy = joint.head_mm
        # Directions away from the neck: along the peg and across it.
        away = [(1, 0), (0, 1), (0, -1)] if joint.axis == "x" else [(0, -1), (1, 0), (-1, 0)]
        def ring(r):
            return np.array([(hx + r * dx, hy + r * dy, z) for dx, dy in away])
        centre = np.array([[hx, hy, z]])
        assert _inside(peg, centre).all() and not _inside(socket, centre).any()
        assert _inside(peg, ring(radius - 0.05)).all()  # the peg's head is the full size
        gap = ring(radius + CLEARANCE_MM / 2)  # between the peg and the socket wall: neither
        assert not _inside(peg, gap).any() and not _inside(socket, gap).any()
        assert _inside(socket, ring(radius + CLEARANCE_MM + 0.05)).all()  # the socket is larger by the clearance


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_tiles_cover_the_plate_without_overlap(tiled):
    litho, tiles, whole, _ = tiled
    rng = np.random.default_rng(0)
    w, d = whole.extents[:2]
    points = np.column_stack([rng.uniform(0, w, 1500), rng.uniform(0, d, 1500), np.full(1500, litho.params.base_mm / 2)])
    points = points[_inside(whole, points)]
    counts = sum(_inside(mesh, points).astype(int) for mesh in tiles.values())
    assert counts.max() == 1  # no point of the plate is in two tiles
    assert (counts == 1).mean() > 0.995  # only the clearance around the pegs is left out
    volumes = sum(m.volume for m in tiles.values())
    assert volumes == pytest.approx(whole.volume, rel=0.02)


@pytest.mark.timeout(120)
def test_description_and_files(tiled):
    litho, _, _, folder = tiled
    text = (folder / "p.description.txt").read_text(encoding="utf-8")
    assert "4 tiles in 2 rows and 2 columns" in text and "socket" in text
    assert not (folder / "p.stl").exists()
    assert all(t.label_on_margin or any("pad" in w for w in litho.report.warnings) for t in litho.tiles.tiles)
    assert math.isclose(litho.tiles.bed_mm[0], 120.0)


@pytest.mark.timeout(120)
def test_a_plate_that_fits_is_not_tiled():
    litho = make_lithograph(np.random.default_rng(1).random((40, 60)), width_mm=60, bed_mm="120")
    assert litho.tiles is None


@pytest.mark.timeout(300)
def test_fept_tiled_for_a_resin_bed_writes_every_tile_sound(tmp_path, fixture, capsys):
    """FePt at 200 mm on the SL1S (127 × 80 mm): the cuts through its fine relief left faces of no
    area in one tile once written as float32, and the run refused to write. Every tile is written,
    and each reads back closed, merged by position as a slicer reads it."""
    from conftest import run_cli
    from tamp_os.mesh.validate import check_as_written, merge_float32
    from tamp_os.mesh.solid import Mesh

    code, out, err = run_cli(capsys, "convert", fixture("fept_spheres_sem.png"), "-o", tmp_path, "--printer", "sl1s",
                             "--width-mm", "200", "--formats", "stl")
    assert code == 0, err
    stls = sorted(tmp_path.glob("*.tile-*.stl"))
    assert len(stls) >= 4, out
    for path in stls:
        read = trimesh.load(path, process=False)
        vertices, faces = merge_float32(np.asarray(read.vertices), np.asarray(read.faces))
        check = check_as_written(Mesh(vertices.astype(np.float64), faces.astype(np.int32)))
        assert check.ok, (path.name, check.problems)
        w, d = sorted(read.extents[:2])
        assert w <= 80 + 1e-6 and d <= 127 + 1e-6, (path.name, read.extents)
