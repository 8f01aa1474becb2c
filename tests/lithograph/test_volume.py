"""`convert --volume` (issue 36): phantoms with known answers, read back as a slicer reads them.

Each phantom is a partial-volume stack (each voxel holds the share of it inside the shape, as a
microscope's voxel does), written as an ImageJ TIFF with its voxel size, so the whole path is
tested: reading, the level, voids, thickening, marching cubes, the budget, the writers.
Lengths in the phantoms are print millimetres (1 µm of sample = 1 mm of model, size_mm = the
shape's analytic extent), so the analytic answers hold on the model directly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import tifffile
import trimesh
from hypothesis import HealthCheck, given, settings, strategies as st

from tamp_os import LithoParams
from tamp_os.lithograph.volume import convert_volume, make_volume
from tamp_os.mesh import budget as mb
from tamp_os.mesh.solid import Mesh


def write_stack(path, sdf_mm, shape, pitch_um=(0.4, 0.4, 0.4), lo=100, hi=1100):
    """A stack whose voxel (z, y, x) centres sit at `pitch_um` steps, value = lo + (hi − lo) × the
    voxel's share inside (sdf > 0), from a signed distance in µm (= model mm)."""
    nz, ny, nx = shape
    dz, dy, dx = pitch_um
    # Centres off the shapes' round numbers, so no surface passes exactly through a row of voxel centres.
    z, y, x = np.meshgrid((np.arange(nz) + 0.37) * dz, (np.arange(ny) + 0.41) * dy, (np.arange(nx) + 0.43) * dx, indexing="ij")
    # Row 0 is the far edge: the phantom's y runs down the rows, so flip it to model coordinates.
    y = ny * dy - y
    share = np.clip(0.5 + sdf_mm(x, y, z) / min(pitch_um), 0, 1)
    stack = (lo + (hi - lo) * share).astype(np.uint16)
    tifffile.imwrite(path, stack, imagej=True, resolution=(1 / dx, 1 / dy),
                     metadata={"spacing": dz, "unit": "um", "axes": "ZYX"})
    return path


def params(**kw):
    base = dict(volume=True, volume_stand="none", iso_level=600.0, formats=("stl",))
    base.update(kw)
    return LithoParams(**base)


def read_back(path) -> trimesh.Trimesh:
    """The STL as a slicer reads it: vertices merged by position."""
    return trimesh.load(path, force="mesh", process=True)


def check_solid_file(path):
    mesh = read_back(path)
    assert mesh.is_watertight, "open or pinched edges once merged by position"
    assert mesh.is_winding_consistent
    assert mesh.volume > 0
    return mesh


def points_on(model: Mesh, n=6000):
    points, _ = mb.sample_surface(model, n, seed=11)
    return points


def walls(model: Mesh, n=6000):
    solid = mb.to_manifold(model)
    points, normals = mb.sample_surface(model, n, seed=12)
    return points, mb.wall_thickness(solid, points, normals, reach_mm=100.0)


@pytest.mark.slow
@pytest.mark.timeout(240)
@pytest.mark.parametrize("thickness", [0.5, 1.0, 2.0])
def test_open_spherical_shells_keep_or_reach_the_wall(tmp_path, thickness):
    """A bowl (a spherical shell open at the top) 0.5, 1 and 2 mm thick: 1 and 2 mm are kept as they are
    (volume within 2 % of the analytic one), 0.5 mm is thickened to at least 1 mm; every wall sampled
    at 5000+ points away from the rim is at least 1 mm."""
    R, cut = 10.0, 5.0  # outer radius, the rim's height above the centre (mm)
    c = np.array([11.0, 11.0, 11.0])

    def sdf(x, y, z):
        r = np.sqrt((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2)
        return np.minimum(np.minimum(R - r, r - (R - thickness)), (c[2] + cut) - z)

    stack = write_stack(tmp_path / "bowl.tif", sdf, (85, 110, 110), pitch_um=(0.2, 0.2, 0.2))
    done = convert_volume(stack, params(size_mm=2 * R, min_wall_mm=1.0), tmp_path)
    model = done.model.model
    check_solid_file(tmp_path / "bowl.stl")
    assert max(done.model.size_mm) == pytest.approx(2 * R, rel=0.005)

    def below_plane(a, zc):
        return math.pi * (a + zc) ** 2 * (2 * a - zc) / 3

    analytic = below_plane(R, cut) - below_plane(R - thickness, cut)
    points, wall = walls(model, 9000)
    z0 = model.vertices[:, 2].min()
    away = points[:, 2] - z0 < (R + cut) - 1.5  # away from the rim, whose edge any ray leaves at once
    assert away.sum() >= 5000
    if thickness > 1.0:
        assert done.model.thin_voxels == 0
        assert model.volume_mm3() == pytest.approx(analytic, rel=0.02)
    elif thickness == 1.0:  # at the threshold: the voxels quantise the wall to 4–6 of 0.2 mm, so parts of it may grow
        assert model.volume_mm3() == pytest.approx(analytic, rel=0.02) or done.model.thin_voxels > 0
        assert analytic * 0.98 <= model.volume_mm3() <= analytic * 1.25
    else:
        assert done.model.thin_voxels > 0 and done.model.thickened_mm > 0
        assert model.volume_mm3() > analytic * 1.5
    assert np.percentile(wall[away], 0.5) >= 0.95, np.percentile(wall[away], [0, 0.5, 1, 5])
    assert done.model.parts == 1 and done.model.genus == 0


@pytest.mark.timeout(180)
def test_torus_genus_volume_and_deviation(tmp_path):
    R, r = 8.0, 3.0
    c = np.array([12.0, 12.0, 6.0])

    def sdf(x, y, z):
        rho = np.sqrt((x - c[0]) ** 2 + (y - c[1]) ** 2)
        return r - np.sqrt((rho - R) ** 2 + (z - c[2]) ** 2)

    stack = write_stack(tmp_path / "torus.tif", sdf, (30, 60, 60))
    done = convert_volume(stack, params(size_mm=2 * (R + r)), tmp_path)
    v = done.model
    mesh = check_solid_file(tmp_path / "torus.stl")
    assert mesh.euler_number == 0  # genus 1: V − E + F = 2 − 2g
    assert v.genus == 1 and v.parts == 1
    assert v.model.volume_mm3() == pytest.approx(2 * math.pi ** 2 * R * r * r, rel=0.02)
    lo, hi = v.model.vertices.min(axis=0), v.model.vertices.max(axis=0)
    assert (hi - lo) == pytest.approx([22.0, 22.0, 6.0], rel=0.005)
    centre = (lo + hi) / 2
    p = points_on(v.model) - centre
    distance = np.abs(np.sqrt((np.hypot(p[:, 0], p[:, 1]) - R) ** 2 + p[:, 2] ** 2) - r)
    assert distance.max() <= 0.1


@pytest.mark.timeout(180)
def test_budget_is_met_within_a_tenth_of_a_millimetre(tmp_path):
    """A torus meshed far above a small budget: simplified to it, still closed, the deviation measured."""
    R, r = 8.0, 3.0

    def sdf(x, y, z):
        rho = np.sqrt((x - 12) ** 2 + (y - 12) ** 2)
        return r - np.sqrt((rho - R) ** 2 + (z - 6) ** 2)

    stack = write_stack(tmp_path / "torus.tif", sdf, (30, 60, 60))
    done = convert_volume(stack, params(size_mm=22.0, max_triangles=8000), tmp_path)
    v = done.model
    assert v.triangles_full > 8000 and v.mesh.n_triangles <= 8000 and v.budget_met
    assert 0 < v.deviation_mm <= 0.1
    check_solid_file(tmp_path / "torus.stl")
    # The measured deviation is the one an independent check finds (trimesh's exact closest points).
    full_points = points_on(v.mesh, 3000)
    p = full_points - (v.model.vertices.min(axis=0) + v.model.vertices.max(axis=0)) / 2
    analytic = np.abs(np.sqrt((np.hypot(p[:, 0], p[:, 1]) - R) ** 2 + p[:, 2] ** 2) - r)
    assert analytic.max() <= 0.1 + 0.05  # the simplified surface from the true torus: within the budget's 0.1 mm of the full one


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_budget_kept_when_a_tenth_of_a_millimetre_cannot_hold(tmp_path):
    """A bumpy ball far over a small budget: no simplification within 0.1 mm reaches 1,000 triangles, so
    the budget is kept (by a coarser grid or a coarser simplification, whichever moves the surface
    least), the deviation from the full-resolution surface is measured, and one line says which was kept."""
    def sdf(x, y, z):
        return 4.5 - np.sqrt((x - 6) ** 2 + (y - 6) ** 2 + (z - 6) ** 2) + 0.5 * np.sin(3 * x) * np.sin(3 * y) * np.sin(3 * z)

    stack = write_stack(tmp_path / "bumpy.tif", sdf, (30, 30, 30))
    done = convert_volume(stack, params(size_mm=11.0, max_triangles=1000), tmp_path)
    v = done.model
    check_solid_file(tmp_path / "bumpy.stl")
    assert v.triangles_full > 1000 and v.mesh.n_triangles <= 1000 and v.budget_met
    assert v.deviation_mm > 0.1
    said = [w for w in v.warnings if "budget was kept" in str(w)]
    assert len(said) == 1 and f"{v.deviation_mm:.2f} mm" in str(said[0]) and "0.1 mm was not" in str(said[0])
    assert "budget was kept" in done.written[-2].read_text()
    # The deviation as an independent measure finds it: the full-resolution model, and distances to dense samples of each surface.
    full = make_volume(stack, params(size_mm=11.0, max_triangles=2_000_000)).model
    from scipy.spatial import cKDTree

    a, b = (trimesh.Trimesh(m.vertices, m.faces) for m in (full, v.model))
    dense_a, dense_b = (trimesh.sample.sample_surface(m, 300_000, seed=5)[0] for m in (a, b))
    far = max(cKDTree(dense_b).query(trimesh.sample.sample_surface(a, 4000, seed=6)[0])[0].max(),
              cKDTree(dense_a).query(trimesh.sample.sample_surface(b, 4000, seed=7)[0])[0].max())
    assert far == pytest.approx(v.deviation_mm, abs=0.06)


def thin_walls(model, n=6000):
    """(sampled surface points, the wall behind each) on the model."""
    return walls(model, n)


def in_boxes(points, regions, margin_mm):
    boxes = np.array([r.box_mm for r in regions]).reshape(-1, 6)
    lo, hi = boxes[:, :3] - margin_mm, boxes[:, 3:] + margin_mm
    return ((points[:, None, :] >= lo[None]) & (points[:, None, :] <= hi[None])).all(axis=2).any(axis=1)


def plate(cx, half_mm=0.25):
    """A square plate 7 mm across, 2 × `half_mm` thick, its faces across x at `cx`."""
    return lambda x, y, z: np.minimum(half_mm - np.abs(x - cx), np.minimum(3.5 - np.abs(y - 5), 3.5 - np.abs(z - 5)))


@pytest.mark.timeout(120)
def test_a_thin_plate_is_thickened_to_the_wall(tmp_path):
    """A plate 0.5 mm thick, alone: grown to at least 1 mm, every one of 6,000 sampled walls."""
    stack = write_stack(tmp_path / "plate.tif", plate(4.0), (50, 50, 40), pitch_um=(0.2, 0.2, 0.2))
    v = convert_volume(stack, params(size_mm=7.0, min_wall_mm=1.0), tmp_path).model
    check_solid_file(tmp_path / "plate.stl")
    assert v.thin_grown == 1 and not v.thin_left and v.parts == 1
    _, wall = thin_walls(v.model)
    assert wall.min() >= 0.95, np.percentile(wall, [0, 1, 5])
    assert min(v.size_mm) >= 0.95  # the plate itself, across


@pytest.mark.timeout(120)
def test_thin_plates_that_thickening_would_join_are_listed(tmp_path):
    """Two plates 0.5 mm thick and 0.5 mm apart: grown to 1 mm they would touch, so both stay as they
    are and are listed (where, how thin, why); every sampled wall under 1 mm lies in a listed region."""
    def sdf(x, y, z):
        return np.maximum(plate(4.0)(x, y, z), plate(5.0)(x, y, z))

    stack = write_stack(tmp_path / "two.tif", sdf, (50, 50, 45), pitch_um=(0.2, 0.2, 0.2))
    done = convert_volume(stack, params(size_mm=7.5, min_wall_mm=1.0), tmp_path)
    v = done.model
    check_solid_file(tmp_path / "two.stl")
    assert v.parts == 2 and v.thin_grown == 0 and len(v.thin_left) == 2
    assert all(r.why == "joins parts that are apart" and 0.25 <= r.thinnest_mm <= 0.75 for r in v.thin_left)  # 0.5 mm, within a voxel
    points, wall = thin_walls(v.model)
    thin = wall < 0.95
    assert thin.sum() > 1000 and in_boxes(points[thin], v.thin_left, 0.3).all()
    assert any("2 thin parts left thinner than 1 mm" in str(w) for w in v.warnings)
    assert "left thinner than 1 mm" in done.written[-2].read_text()


@pytest.mark.timeout(120)
def test_a_thin_washer_keeps_its_hole(tmp_path):
    """A washer 0.5 mm thick around a hole 0.7 mm across: grown to 1 mm it would close the hole, so it
    stays thin (one hole through it) and is listed."""
    def sdf(x, y, z):
        rho = np.hypot(x - 5, y - 5)
        return np.minimum(np.minimum(0.25 - np.abs(z - 3), 4 - rho), rho - 0.35)

    stack = write_stack(tmp_path / "washer.tif", sdf, (30, 50, 50), pitch_um=(0.2, 0.2, 0.2))
    v = convert_volume(stack, params(size_mm=8.0, min_wall_mm=1.0), tmp_path).model
    mesh = check_solid_file(tmp_path / "washer.stl")
    assert v.genus == 1 and mesh.euler_number == 0
    assert len(v.thin_left) == 1 and v.thin_left[0].why == "closes a hole or a pocket"
    points, wall = thin_walls(v.model)
    assert in_boxes(points[wall < 0.95], v.thin_left, 0.3).all()


@pytest.mark.timeout(180)
def test_two_touching_spheres_are_one_part(tmp_path):
    a, d = 5.0, 9.6
    c1, c2 = np.array([6.0, 8.0, 6.0]), np.array([6.0 + d, 8.0, 6.0])

    def sdf(x, y, z):
        r1 = np.sqrt((x - c1[0]) ** 2 + (y - c1[1]) ** 2 + (z - c1[2]) ** 2)
        r2 = np.sqrt((x - c2[0]) ** 2 + (y - c2[1]) ** 2 + (z - c2[2]) ** 2)
        return np.maximum(a - r1, a - r2)

    stack = write_stack(tmp_path / "two.tif", sdf, (30, 40, 55))
    done = convert_volume(stack, params(size_mm=2 * a + d), tmp_path)
    v = done.model
    check_solid_file(tmp_path / "two.stl")
    lens = math.pi * (4 * a + d) * (2 * a - d) ** 2 / 12
    assert v.model.volume_mm3() == pytest.approx(2 * 4 / 3 * math.pi * a ** 3 - lens, rel=0.02)
    assert v.parts == 1 and v.genus == 0


@pytest.mark.timeout(180)
def test_hollow_cube_void_is_filled(tmp_path):
    side, hole = 16.0, 8.0
    c = 10.0

    def sdf(x, y, z):
        outer = side / 2 - np.maximum(np.maximum(np.abs(x - c), np.abs(y - c)), np.abs(z - c))
        inner = hole / 2 - np.maximum(np.maximum(np.abs(x - c), np.abs(y - c)), np.abs(z - c))
        return np.minimum(outer, -inner)

    stack = write_stack(tmp_path / "box.tif", sdf, (50, 50, 50))
    done = convert_volume(stack, params(size_mm=side), tmp_path)
    v = done.model
    mesh = check_solid_file(tmp_path / "box.stl")
    assert len(mesh.split(only_watertight=False)) == 1  # one shell: the void's inner surface is gone
    assert mesh.euler_number == 2
    assert v.voids_filled == 1 and v.parts == 1
    assert v.model.volume_mm3() == pytest.approx(side ** 3, rel=0.02)
    assert "void" in done.written[-2].read_text()  # the description says it


@pytest.mark.timeout(180)
def test_anisotropic_stack_keeps_its_shape(tmp_path):
    """z slices three times as far apart as the pixels: the sphere stays a sphere, not a pancake."""
    a = 6.0

    def sdf(x, y, z):
        return a - np.sqrt((x - 8) ** 2 + (y - 8) ** 2 + (z - 8) ** 2)

    stack = write_stack(tmp_path / "aniso.tif", sdf, (14, 40, 40), pitch_um=(1.2, 0.4, 0.4))
    done = convert_volume(stack, params(size_mm=2 * a), tmp_path)
    v = done.model
    check_solid_file(tmp_path / "aniso.stl")
    x, y, z = v.size_mm
    assert z / x == pytest.approx(1.0, rel=0.03)
    assert v.model.volume_mm3() == pytest.approx(4 / 3 * math.pi * a ** 3, rel=0.02)
    assert v.voxel_m[0] / v.voxel_m[2] == pytest.approx(3.0)


@pytest.mark.timeout(240)
def test_on_its_base_with_the_furniture(tmp_path):
    """The default: the model fused on a base plate with braille, scale bar and cut corner; 3MF and GLB too."""
    def sdf(x, y, z):
        return 6.0 - np.sqrt((x - 8) ** 2 + (y - 8) ** 2 + (z - 8) ** 2)

    stack = write_stack(tmp_path / "ball.tif", sdf, (40, 40, 40))
    p = LithoParams(volume=True, size_mm=40.0, formats=("stl", "3mf", "glb"), caption="ball")
    done = convert_volume(stack, p, tmp_path)
    v = done.model
    assert [f.name for f in done.written] == ["ball.stl", "ball.3mf", "ball.glb", "ball.description.txt", "ball.tamp.json"]
    mesh = check_solid_file(tmp_path / "ball.stl")
    assert len(mesh.split(only_watertight=False)) == 1  # the ball is fused to its base
    assert v.plate_mm is not None and v.caption_braille and v.scale_label
    assert mesh.bounds[0][2] == pytest.approx(0.0, abs=1e-6)  # it stands on the base
    text = done.written[3].read_text()
    assert "1 mm on the model is" in text and "braille caption" in text
    import lib3mf

    wrapper = lib3mf.Wrapper()
    model3mf = wrapper.CreateModel()
    model3mf.QueryReader("3mf").ReadFromFile(str(tmp_path / "ball.3mf"))
    assert model3mf.GetMeshObjects().MoveNext()


@pytest.mark.slow
@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(radius=st.floats(3.0, 7.0), size=st.floats(20.0, 80.0), shift=st.floats(-1.0, 1.0))
@pytest.mark.timeout(300)
def test_any_ball_is_a_closed_solid_at_the_size_asked(tmp_path, radius, size, shift):
    def sdf(x, y, z):
        return radius - np.sqrt((x - 8 - shift) ** 2 + (y - 8) ** 2 + (z - 8 + shift) ** 2)

    stack = write_stack(tmp_path / "b.tif", sdf, (40, 40, 40))
    done = convert_volume(stack, LithoParams(volume=True, volume_stand="none", size_mm=size), tmp_path)
    check_solid_file(tmp_path / "b.stl")
    assert max(done.model.size_mm) == pytest.approx(size, rel=0.005)
    assert done.model.level_from == "Otsu"


# Bad input: one clear message each, no traceback.

def run_cli(args, capsys):
    from tamp_os.cli import main

    code = main(args)
    out = capsys.readouterr()
    assert "Traceback" not in out.err
    return code, out.err


@pytest.mark.timeout(60)
def test_one_plane_is_refused(tmp_path, capsys):
    path = tmp_path / "flat.tif"
    tifffile.imwrite(path, np.random.default_rng(0).integers(0, 4000, (64, 64)).astype(np.uint16))
    code, err = run_cli(["convert", str(path), "--volume", "-o", str(tmp_path / "out")], capsys)
    assert code == 1 and "single plane" in err and "--volume" in err and str(path) in err


@pytest.mark.timeout(60)
def test_the_real_single_plane_file_is_refused(fixture, tmp_path, capsys):
    code, err = run_cli(["convert", str(fixture("real/confocal_membranes_cells3d.tif")), "--volume", "-o", str(tmp_path)], capsys)
    assert code == 1 and "single plane" in err


@pytest.mark.timeout(60)
def test_empty_stack_is_refused(tmp_path, capsys):
    path = tmp_path / "empty.tif"
    tifffile.imwrite(path, np.zeros((5, 32, 32), np.uint16), imagej=True, metadata={"axes": "ZYX"})
    code, err = run_cli(["convert", str(path), "--volume", "-o", str(tmp_path / "out")], capsys)
    assert code == 1 and "blank" in err and "every voxel is 0" in err


@pytest.mark.timeout(60)
def test_a_level_without_surface_is_refused(tmp_path, capsys):
    path = write_stack(tmp_path / "ball.tif", lambda x, y, z: 4 - np.sqrt((x - 5) ** 2 + (y - 5) ** 2 + (z - 5) ** 2), (25, 25, 25))
    code, err = run_cli(["convert", str(path), "--volume", "--iso-level", "5000", "-o", str(tmp_path / "out")], capsys)
    assert code == 1 and "--iso-level" in err and "100 to 1100" in err and "5000" in err  # a value wrong for this file: exit 1


@pytest.mark.timeout(60)
def test_a_model_of_nothing_but_specks_is_refused(tmp_path, capsys):
    stack = np.zeros((40, 40, 40), np.uint16)
    stack[20, 20, 20] = 1000
    path = tmp_path / "speck.tif"
    tifffile.imwrite(path, stack, imagej=True, metadata={"axes": "ZYX"})
    code, err = run_cli(["convert", str(path), "--volume", "--size-mm", "5", "--volume-stand", "none", "-o", str(tmp_path / "out")], capsys)
    assert code == 1 and "only specks" in err and "--iso-level" in err
    assert not (tmp_path / "out" / "speck.stl").exists()


@pytest.mark.timeout(60)
def test_a_flat_format_is_a_usage_error(tmp_path, capsys):
    path = write_stack(tmp_path / "ball.tif", lambda x, y, z: 4 - np.sqrt((x - 5) ** 2 + (y - 5) ** 2 + (z - 5) ** 2), (25, 25, 25))
    code, err = run_cli(["convert", str(path), "--volume", "--formats", "pdf", "-o", str(tmp_path / "out")], capsys)
    assert code == 1 and "--formats" in err and "pdf" in err


@pytest.mark.timeout(60)
def test_the_memory_is_priced_before_reading(tmp_path, capsys):
    path = tmp_path / "big.tif"
    tifffile.imwrite(path, np.zeros((4, 64, 64), np.uint16) + 7, imagej=True, metadata={"axes": "ZYX"})
    code, err = run_cli(["convert", str(path), "--volume", "--max-memory-gb", "0.00001", "-o", str(tmp_path / "out")], capsys)
    assert code == 1 and "--max-memory-gb" in err


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", ["confocal_beads_zstack_41z.tif", "nikon_widefield_zstack_11z.nd2", "mrc_emdb3197_subtomo.map"])
def test_real_stacks_become_closed_solids(fixture, tmp_path, name):
    done = convert_volume(fixture("real/" + name), LithoParams(volume=True), tmp_path)
    check_solid_file(done.written[0])
    v = done.model
    assert v.voxel_m is not None and v.sample_m_per_mm
    assert max(v.size_mm) == pytest.approx(100.0, rel=0.005)
    assert v.deviation_mm <= 0.1


@pytest.mark.timeout(120)
def test_orientation_top_row_far_and_first_slice_low(tmp_path):
    """An asymmetric stack: a cube in the first rows, first columns and first slices, a long bar in the
    last rows and last slices. Seen from above the model looks like the image (row 0 at the far edge,
    +y), and z is the slice index, up."""
    stack = np.zeros((30, 40, 50), np.uint16)
    stack[2:10, 2:10, 2:10] = 1000  # first slices, top rows, left columns
    stack[20:28, 30:38, 5:45] = 1000  # last slices, bottom rows, a bar along x
    path = tmp_path / "asym.tif"
    tifffile.imwrite(path, stack, imagej=True, resolution=(1.0, 1.0), metadata={"spacing": 1.0, "unit": "um", "axes": "ZYX"})
    done = convert_volume(path, LithoParams(volume=True, volume_stand="none", size_mm=40.0), tmp_path)
    mesh = read_back(tmp_path / "asym.stl")
    parts = sorted(mesh.split(only_watertight=True), key=lambda m: m.volume)
    cube, bar = parts[0], parts[-1]
    assert done.model.parts == 2
    assert cube.centroid[1] > bar.centroid[1]  # the top rows lie at the far edge
    assert cube.centroid[2] < bar.centroid[2]  # the first slices lie low
    assert cube.centroid[0] < bar.centroid[0]  # the left columns lie left
    assert np.ptp(bar.vertices[:, 0]) > 3 * np.ptp(bar.vertices[:, 1])  # the bar runs along x


@pytest.mark.timeout(60)
def test_batch_does_not_make_a_relief_of_a_volume_silently(tmp_path):
    from tamp_os.errors import ParameterError
    from tamp_os.lithograph.convert import convert

    with pytest.raises(ParameterError, match="volume"):
        convert(np.zeros((8, 8)), LithoParams(volume=True), tmp_path)


@pytest.mark.timeout(120)
def test_a_budget_the_base_alone_exceeds_is_said_with_the_budget_that_fits(tmp_path):
    """The whole file counts: when the plate, its braille and scale bar alone take more than
    `max_triangles`, the model still prints and the warning says how many the file has and what to give."""
    import re

    stack = write_stack(tmp_path / "ball.tif", lambda x, y, z: 5 - np.sqrt((x - 8) ** 2 + (y - 8) ** 2 + (z - 8) ** 2), (20, 20, 20))
    done = convert_volume(stack, LithoParams(volume=True, size_mm=30.0, max_triangles=1000), tmp_path)
    check_solid_file(done.written[0])
    said = " ".join(str(w) for w in done.model.warnings)
    found = re.search(r"the file has ([\d,]+) triangles, over max_triangles 1,000: .* alone takes ([\d,]+)\. Give max_triangles at least ([\d,]+)", said)
    assert found, said
    total, base, enough = (int(g.replace(",", "")) for g in found.groups())
    assert total == done.model.mesh.n_triangles > 1000 and base < total and enough > base
