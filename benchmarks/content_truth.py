"""Pictures with truth for the content benchmark (issue 26): the synthetic ones of
tests/synthetic_content.py, and real micrographs from ../shared/fixtures with truth masks made
here by a threshold or blob detection (each checked by eye against its source; how is said at
each loader). Each picture is prepared as the pipeline does at Medium: 250 px across 100 mm,
2–98 % stretch, blur 1.2 px; truth is resampled to that grid (nearest).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage
from skimage import feature, filters, morphology, segmentation

from synthetic_content import Truth, all_content, sparse_beads, sparse_strokes
from tamp_os.relief.preprocess import prepare

FIXTURES = Path(__file__).resolve().parents[2] / "shared" / "fixtures"
COLS = 250
WIDTH_MM = 100.0


@dataclass(frozen=True)
class Case:
    name: str
    image01: np.ndarray  # prepared, on the Medium grid
    mm_per_px: float
    truth: Truth | None  # on the same grid; None when the picture was skipped
    skipped: str = ""  # why, when skipped
    how: str = ""  # how the truth was made
    fine: object = None  # Prepared.finer: the picture without the print grid's blur, as the pipeline passes it


def _prepared(values: np.ndarray):
    """(image on the Medium grid, mm per px, Prepared.finer)."""
    rows = max(2, round(values.shape[0] * (COLS - 1) / (values.shape[1] - 1)) )
    prepared = prepare(values.astype(np.float32), None, rows=rows, cols=COLS, target_aspect=(rows - 1) / (COLS - 1), fit="stretch",
                       low_pct=2, high_pct=98, sigma_px=1.2, invert=False, flip_x=False)
    return prepared.image, WIDTH_MM / (COLS - 1), prepared.finer


def _to_grid(a: np.ndarray | None, shape) -> np.ndarray | None:
    if a is None:
        return None
    zoom = (shape[0] / a.shape[0], shape[1] / a.shape[1])
    return ndimage.zoom(a, zoom, order=0, grid_mode=True, mode="grid-constant")[: shape[0], : shape[1]]


def _members_by_threshold(values: np.ndarray, sigma: float, min_distance: int, min_px: int, exclude=None,
                          noise_sigmas: float | None = None, peak_sigma: float | None = None) -> np.ndarray:
    """Otsu of the smoothed picture (or, with noise_sigmas, the median plus that many robust
    deviations: for sparse members), touching members split by a watershed of the distance (or,
    with peak_sigma, of the brightness smoothed by that many px from its peaks: spheres in HAADF
    STEM are brightest at their centres, thickest there, while packed ones' outline has no neck)."""
    smooth = filters.gaussian(values.astype(np.float64), sigma, preserve_range=True)
    sample = smooth if exclude is None else smooth[~exclude]
    if noise_sigmas is None:
        thresh = filters.threshold_otsu(sample)
    else:
        med = np.median(sample)
        thresh = med + noise_sigmas * 1.4826 * np.median(np.abs(sample - med))
    mask = smooth > thresh
    if exclude is not None:
        mask &= ~exclude
    dist = ndimage.distance_transform_edt(mask) if peak_sigma is None else filters.gaussian(values.astype(np.float64), peak_sigma, preserve_range=True)
    peaks = feature.peak_local_max(dist, min_distance=min_distance, labels=ndimage.label(mask)[0], exclude_border=False)
    markers = np.zeros(mask.shape, np.int32)
    markers[tuple(peaks.T)] = np.arange(1, len(peaks) + 1)
    labels = segmentation.watershed(-dist, markers, mask=mask)
    small = np.bincount(labels.ravel()) < min_px
    small[0] = True
    labels = np.where(small[labels], 0, labels)
    return segmentation.relabel_sequential(labels)[0].astype(np.int32)


def _no_short(skeleton: np.ndarray, min_px: int) -> np.ndarray:
    parts, _ = ndimage.label(skeleton, structure=np.ones((3, 3)))
    keep = np.bincount(parts.ravel()) >= min_px
    keep[0] = False
    return keep[parts]


def _case(name, values, members=None, lines=None, how="", grains=None) -> Case:
    image, mm, finer = _prepared(values)
    truth = Truth(name, image, members=_to_grid(members, image.shape), lines=None if lines is None else _to_grid(lines.astype(np.uint8), image.shape) > 0,
                  grains=_to_grid(grains, image.shape))
    return Case(name, image, mm, truth, how=how, fine=finer)


def _skip(name, why) -> Case:
    return Case(name, np.zeros((2, 2), np.float32), 1.0, None, skipped=why)


def real_cases() -> list[Case]:
    import tifffile

    out = []
    # FePt spheres: four disks measured by eye (as tests/test_relief_styles.py's FEPT_SPHERES).
    from PIL import Image

    fept = np.asarray(Image.open(FIXTURES / "fept_spheres_sem.png").convert("L"), np.float32)
    rows, cols = fept.shape
    yy, xx = np.mgrid[0:rows, 0:cols] / (cols - 1)
    labels = np.zeros(fept.shape, np.int32)
    for k, (x, y, r) in enumerate([(0.20, 0.38, 0.187), (0.567, 0.24, 0.173), (0.46, 0.63, 0.171), (0.807, 0.56, 0.187)], 1):
        labels[((xx - x) ** 2 + (yy - y * (rows - 1) / (cols - 1)) ** 2 <= (0.9 * r) ** 2) & (labels == 0)] = k
    out.append(_case("fept_spheres_sem.png", fept, members=labels, how="4 disks measured by eye (0.9 of each radius)"))
    # SEM SiO2 particle fields: Otsu of the picture smoothed by 2 px (35kx) / 1 px (10kx), split by
    # a distance watershed; only the rows above the burned-in databar box (rows 423–462).
    for tag, sigma, dist, min_px in (("35kx", 2.0, 9, 120), ("10kx", 1.0, 3, 12)):
        path = FIXTURES / "real" / f"sem_fei_sio2_particles_{tag}.tif"
        values = tifffile.imread(path).astype(np.float32)
        if values.ndim == 3:
            values = values[..., 0]
        values = values[:418]  # the picture above the burned-in databar box (rows 423-462): the box is not content
        members = _members_by_threshold(values, sigma, dist, min_px)
        out.append(_case(path.name, values, members=members, how=f"Otsu after a {sigma:g} px Gaussian, distance watershed (min distance {dist} px), rows above the databar box"))
    # Confocal beads: max projection; 4 beads at the README's positions, disks 12 px across (the visible bead, checked by eye).
    stack = tifffile.imread(FIXTURES / "real" / "confocal_beads_zstack_41z.tif").astype(np.float32)
    mip = stack.max(axis=0)
    yy, xx = np.mgrid[0 : mip.shape[0], 0 : mip.shape[1]]
    labels = np.zeros(mip.shape, np.int32)
    for k, (x, y) in enumerate([(124, 35), (29, 72), (75, 82), (43, 111)], 1):
        labels[(xx - x) ** 2 + (yy - y) ** 2 <= 6**2] = k
    out.append(_case("confocal_beads_zstack_41z.tif (max projection)", mip, members=labels, how="4 beads at the fixture README's positions, disks 12 px across (the visible bead, checked by eye)"))
    # Confocal membranes: bright lines = white top-hat (disk 6 px) above Otsu, thinned; the two
    # bright cell bodies (filled blobs thicker than 5 px) are not lines.
    mem = tifffile.imread(FIXTURES / "real" / "confocal_membranes_cells3d.tif").astype(np.float32)
    smooth = filters.gaussian(mem, 1.0, preserve_range=True)
    hat = morphology.white_tophat(smooth, morphology.disk(6))
    lines = hat > filters.threshold_otsu(hat)
    thick = ndimage.distance_transform_edt(smooth > filters.threshold_otsu(smooth)) > 5
    lines &= ~ndimage.binary_dilation(thick, iterations=8)
    lines = _no_short(morphology.skeletonize(lines), 15)
    out.append(_case("confocal_membranes_cells3d.tif", mem, lines=ndimage.binary_dilation(lines), how="white top-hat (disk 6) > Otsu, skeleton, cell bodies removed"))
    # Nikon widefield membranes (ND2 z-stack, max projection as the pipeline prints it): bright
    # outlines = above Otsu after a 1 px Gaussian, thinned, spurs under 10 px dropped.
    try:
        import nd2
    except ImportError as exc:
        out.append(_skip("nikon_widefield_zstack_11z.nd2", f"no ND2 reader ({exc})"))
    else:
        planes = np.asarray(nd2.imread(FIXTURES / "real" / "nikon_widefield_zstack_11z.nd2"), np.float32)
        mip = planes.reshape(-1, *planes.shape[-2:]).max(axis=0)
        smooth = filters.gaussian(mip, 1.0, preserve_range=True)
        outline = _no_short(morphology.skeletonize(smooth > filters.threshold_otsu(smooth)), 10)
        out.append(_case("nikon_widefield_zstack_11z.nd2 (max projection)", mip, lines=ndimage.binary_dilation(outline),
                         how="above Otsu after a 1 px Gaussian, skeleton, spurs under 10 px dropped"))
    # STEM HAADF SiO2 spheres (hspy) and Velox EMD particles: RosettaSciIO when importable.
    try:
        from rsciio.hspy import file_reader as hspy_reader
        from rsciio.emd import file_reader as emd_reader
    except Exception as exc:  # noqa: BLE001 - any import failure means: skip, and say so
        out += [_skip("stem_haadf_sio2_spheres.hspy", f"no reader ({exc})"), _skip("velox_talos_haadf_particles.emd", f"no reader ({exc})")]
    else:
        stem = np.asarray(hspy_reader(str(FIXTURES / "real" / "stem_haadf_sio2_spheres.hspy"))[0]["data"], np.float32)
        out.append(_case("stem_haadf_sio2_spheres.hspy", stem, members=_members_by_threshold(stem, 0.7, 2, 12, peak_sigma=1.0),
                         how="Otsu after a 0.7 px Gaussian, parted by a watershed from the brightness peaks after a 1 px "
                             "Gaussian, at least 2 px apart (one per sphere: the README's 170-220)"))
        emd = np.asarray(emd_reader(str(FIXTURES / "real" / "velox_talos_haadf_particles.emd"))[0]["data"], np.float32)
        edge = np.zeros(emd.shape, bool)
        edge[:60, 420:] = True  # the grid bar, top right corner, is not a particle
        out.append(_case("velox_talos_haadf_particles.emd", emd, members=_members_by_threshold(emd, 2.0, 10, 40, exclude=edge, noise_sigmas=8),
                         how="median + 8 robust deviations after a 2 px Gaussian, distance watershed (min distance 10 px), grid-bar corner excluded"))
        from rsciio.tia import file_reader as tia_reader

        tia = np.asarray(tia_reader(str(FIXTURES / "real" / "tia_talos_tem_search.emi"))[0]["data"], np.float32)
        dark = filters.gaussian(tia, 1.0, preserve_range=True) < filters.threshold_otsu(tia)
        needle, _ = ndimage.label(dark)
        needle = (needle == np.argmax(np.bincount(needle.ravel())[1:]) + 1).astype(np.int32)  # the one object (README: 19 %)
        out.append(_case("tia_talos_tem_search.emi (TEM needle)", tia, members=needle,
                         how="below Otsu after a 1 px Gaussian, the largest region: the needle, one member"))
    out += lattice_cases()
    try:
        import czifile
    except ImportError:
        out.append(_skip("zeiss_sem_al2o3_grains.czi", "no CZI reader importable (czifile)"))
    else:
        grains = np.squeeze(czifile.imread(FIXTURES / "real" / "zeiss_sem_al2o3_grains.czi")).astype(np.float32)
        hat = morphology.white_tophat(filters.gaussian(grains, 2, preserve_range=True), morphology.disk(8))
        lines = _no_short(morphology.skeletonize(hat > filters.threshold_otsu(hat)), 40)
        out.append(_case("zeiss_sem_al2o3_grains.czi", grains, lines=ndimage.binary_dilation(lines, iterations=2),
                         how="white top-hat (disk 8) > Otsu, skeleton"))
    return out


def synthetic_cases() -> list[Case]:
    out = []
    for t in all_content(192, 256):
        rows, cols = t.image.shape
        image = prepare(t.image, None, rows=rows, cols=cols, target_aspect=(rows - 1) / (cols - 1), fit="stretch",
                        low_pct=2, high_pct=98, sigma_px=1.2, invert=False, flip_x=False).image
        out.append(Case(f"synthetic {t.name}", image, WIDTH_MM / (cols - 1), t, how="exact"))
    return out


def sparse_cases() -> list[Case]:
    """Sparse content under the stretch's percentiles (exact truth, 800 px across): ink strokes
    covering 0.5 and 1 % of a drawing, three beads covering 0.3 % of a dark field."""
    out = []
    for t in (sparse_strokes(ink_pct=0.5), sparse_strokes(ink_pct=1.0), sparse_beads(count=3, cover_pct=0.3)):
        out.append(_case(f"synthetic {t.name}", t.image, members=t.members, lines=t.lines, how="exact"))
    return out


def _lattice_case(name, values, min_distance: int, how: str) -> Case:
    """A lattice's truth: its atomic columns, the local maxima of the picture after a 1.5 px
    Gaussian at least `min_distance` px apart (as the fixture README counts them), each a disk on
    the Medium grid a fifth of the median nearest-neighbour spacing across (at least 3 px)."""
    from scipy.spatial import cKDTree

    x = values.astype(np.float64)
    smooth = filters.gaussian((x - x.mean()) / max(float(x.std()), 1e-12), 1.5)
    peaks = feature.peak_local_max(smooth, min_distance=min_distance, exclude_border=False)
    image, mm, finer = _prepared(values)
    scale = (np.array(image.shape, np.float64) - 1) / (np.array(values.shape, np.float64) - 1)
    centres = peaks * scale
    spacing = float(np.median(cKDTree(centres).query(centres, k=2)[0][:, 1]))
    radius = max(1.0, spacing / 5)
    yy, xx = np.mgrid[0 : image.shape[0], 0 : image.shape[1]]
    labels = np.zeros(image.shape, np.int32)
    for k, (cy, cx) in enumerate(centres, 1):
        r0, r1 = int(max(0, cy - radius - 1)), int(min(image.shape[0], cy + radius + 2))
        c0, c1 = int(max(0, cx - radius - 1)), int(min(image.shape[1], cx + radius + 2))
        disk = (yy[r0:r1, c0:c1] - cy) ** 2 + (xx[r0:r1, c0:c1] - cx) ** 2 <= radius**2
        labels[r0:r1, c0:c1][disk & (labels[r0:r1, c0:c1] == 0)] = k
    labels = segmentation.relabel_sequential(labels)[0].astype(np.int32)
    truth = Truth(name, image, members=labels, pitch_px=spacing)
    return Case(name, image, mm, truth, how=how + f" ({len(peaks)} columns, {spacing * mm:.1f} mm apart on the print)", fine=finer)


def lattice_cases() -> list[Case]:
    """The two atomic-resolution lattices of the fixture README (issue 32): the PTO/SRO HAADF
    superlattice (≈600 columns, local maxima 9 px apart) and the ZnO dDPC dumbbells (≈1700 spots,
    5 px apart)."""
    import tifffile

    out = []
    try:
        from rsciio.hspy import file_reader as hspy_reader
    except Exception as exc:  # noqa: BLE001 - any import failure means: skip, and say so
        out.append(_skip("stem_haadf_pto_sro_superlattice.hspy", f"no reader ({exc})"))
    else:
        pto = np.asarray(hspy_reader(str(FIXTURES / "real" / "stem_haadf_pto_sro_superlattice.hspy"))[0]["data"], np.float32)
        out.append(_lattice_case("stem_haadf_pto_sro_superlattice.hspy", pto, 9, "local maxima 9 px apart after a 1.5 px Gaussian"))
    zno = tifffile.imread(FIXTURES / "real" / "stem_ddpc_zno_dumbbells.tif").astype(np.float32)
    out.append(_lattice_case("stem_ddpc_zno_dumbbells.tif", zno, 5, "local maxima 5 px apart after a 1.5 px Gaussian"))
    return out
